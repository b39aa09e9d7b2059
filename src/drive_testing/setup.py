from setuptools import find_packages, setup

package_name = 'drive_testing'

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
    description='Test and benchmark tooling of the DTC drive stack (harness, fixtures, stand-in controllers).',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={'console_scripts': [
        'message_echo = drive_testing.message_echo:main',
        'fixed_responder = drive_testing.fixed_responder:main',
        'raw_responder = drive_testing.ceiling:main',
        'naive_responder = drive_testing.ceiling:naive_main',
        'replay_responder = drive_testing.replay_responder:main',
    ]},
)
