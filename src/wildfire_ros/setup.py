from setuptools import find_packages, setup

package_name = "wildfire_ros"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    # data/fastdds_loopback.xml is config/fastdds_loopback.xml (a symlink in the source tree,
    # copied into wheels and colcon installs): the runtime applies it by default.
    package_data={package_name: ["py.typed", "data/*.xml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=[
        "setuptools",
        "numpy",
        "pyyaml",
        "cyclonedds",
        "rosbags",
        "mcap",
        "zstandard",
        "wildfire_msgs_py",
    ],
    zip_safe=True,
    maintainer="Wildfire surveillance maintainers",
    maintainer_email="wildfire@example.org",
    description=(
        "ROS 2 runtime of the wildfire system: backend binding (rclpy or our Cyclone DDS "
        "layer), node support, loopback network defaults, rosbag2 MCAP recording and playback."
    ),
    license="Apache-2.0",
    entry_points={
        "console_scripts": [],
    },
)
