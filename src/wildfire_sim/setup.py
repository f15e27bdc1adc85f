from setuptools import find_packages, setup

package_name = "wildfire_sim"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    package_data={package_name: ["py.typed", "fuel_tables/*.yaml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=[
        "setuptools",
        "numpy",
        "torch",
        "scipy",
        "pyyaml",
        "rasterio",
        "wildfire_msgs_py",
        "wildfire_ros",
    ],
    zip_safe=True,
    maintainer="Wildfire surveillance maintainers",
    maintainer_email="wildfire@example.org",
    description="Stochastic wildfire model (batched) and the fire-simulator node.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "fire_simulator = wildfire_sim.fire_simulator_node:main",
        ],
    },
)
