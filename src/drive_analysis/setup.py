from setuptools import find_packages, setup

package_name = 'drive_analysis'

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
    description='Analysis of drive runs without ROS: the seeds\' metrics (one registry), figures and the analyze command.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'analyze = drive_analysis.cli:main',
        ],
    },
)
