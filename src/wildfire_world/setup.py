from setuptools import find_packages, setup

package_name = "wildfire_world"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    package_data={package_name: ["py.typed"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=[
        "setuptools",
        "numpy",
        "torch",
        "wildfire_msgs_py",
        "wildfire_ros",
        "wildfire_sim",
        "wildfire_belief",
        "wildfire_agent",
    ],
    zip_safe=True,
    maintainer="Wildfire surveillance maintainers",
    maintainer_email="wildfire@example.org",
    description=(
        "The batched multi-agent wildfire world: vector environment, team sensing and radio, "
        "PettingZoo wrapper."
    ),
    license="Apache-2.0",
    entry_points={
        "console_scripts": [],
    },
)
