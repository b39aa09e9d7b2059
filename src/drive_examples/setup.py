from setuptools import find_packages, setup

package_name = 'drive_examples'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml', 'README.md']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='DTC drive stack maintainers',
    maintainer_email='maintainers@dtc-drive-stack.org',
    description='Worked examples of the public controller API (write your own controller).',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={'console_scripts': [
        'hysteresis_current_controller = drive_examples.hysteresis_current_controller:main',
        'scripted_run = drive_examples.scripted_run:main',
    ]},
)
