from setuptools import find_packages, setup

package_name = "wildfire_bringup"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    package_data={package_name: ["py.typed"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/launch", ["launch/wildfire_launch.py"]),
        ("share/" + package_name + "/config", ["config/wildfire.yaml"]),
    ],
    install_requires=[
        "setuptools",
        "numpy",
        "pyyaml",
        "wildfire_msgs_py",
        "wildfire_ros",
        "wildfire_sim",
        "wildfire_belief",
        "wildfire_agent",
        "wildfire_testbed",
        "foxglove-sdk",
    ],
    entry_points={
        "console_scripts": [
            "live_view = wildfire_bringup.live_view_node:main",
        ],
    },
    zip_safe=True,
    maintainer="Wildfire surveillance maintainers",
    maintainer_email="wildfire@example.org",
    description=(
        "Launch files, default parameters and the launcher that brings a whole system up "
        "(wildfire run), with its run monitor node and the Foxglove live view."
    ),
    license="Apache-2.0",
)
