from glob import glob

from setuptools import find_packages, setup

package_name = 'drive_bringup'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/scenarios', glob('scenarios/*')),
        ('share/' + package_name + '/studies', glob('studies/*')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='DTC drive stack maintainers',
    maintainer_email='maintainers@dtc-drive-stack.org',
    description='Scenarios, the launch-free scenario runner, the headless runner and the seed reproduction table of the DTC drive stack.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'run_scenario = drive_bringup.runner_cli:main',
            'reproduce = drive_bringup.reproduce:main',
            'study = drive_bringup.study_cli:main',
            'split_hosts = drive_bringup.split_hosts:main',
        ],
    },
)
