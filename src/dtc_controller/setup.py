from setuptools import find_packages, setup

package_name = 'dtc_controller'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),

    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='DTC drive stack maintainers',
    maintainer_email='maintainers@dtc-drive-stack.org',
    description='Direct torque control of BLDC and PM brushless AC motors: two- and three-phase conduction, six- and four-switch inverters, sensorless DTIFC, inverter voltage-drop compensation; the dtc_controller node.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'dtc_controller = dtc_controller.dtc_node:main',
        ],
    },
)
