from setuptools import find_packages, setup

package_name = "wildfire_testbed"

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
        "wildfire_msgs_py",
        "wildfire_ros",
    ],
    zip_safe=True,
    maintainer="Wildfire surveillance maintainers",
    maintainer_email="wildfire@example.org",
    description=(
        "Test and fault tools: virtual hosts in network namespaces, link faults (netem, "
        "partitions) and a hostile-input wire fuzzer."
    ),
    license="Apache-2.0",
)
