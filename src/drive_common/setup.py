from setuptools import find_packages, setup

package_name = 'drive_common'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    package_data={package_name: ['*.xml']},
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='DTC drive stack maintainers',
    maintainer_email='maintainers@dtc-drive-stack.org',
    description='Runtime shared by the DTC drive stack nodes: parameter schema, node main, lockstep I/O, topics.',
    license='Apache-2.0',
    tests_require=['pytest'],
)
