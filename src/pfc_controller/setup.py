from setuptools import find_packages, setup

package_name = 'pfc_controller'

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
    description='Average-current-control boost power factor correction (dissertation ch. III); the pfc_controller node.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'pfc_controller = pfc_controller.pfc_node:main',
        ],
    },
)
