from setuptools import find_packages, setup

package_name = "wildfire_agent"

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
        "scipy",
        "torch",
        "wildfire_msgs_py",
        "wildfire_ros",
        "wildfire_sim",
        "wildfire_belief",
    ],
    zip_safe=True,
    maintainer="Wildfire surveillance maintainers",
    maintainer_email="wildfire@example.org",
    description=(
        "Dubins aircraft, sensor model, rewards, policies (TorchScript, "
        "receding horizon, random) and the agent node."
    ),
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "agent = wildfire_agent.agent_node:main",
            "agent_group = wildfire_agent.agent_group:main",
        ],
    },
)
