from setuptools import find_packages, setup

package_name = 'drive_logger'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/layouts', ['layouts/dtc_live.json', 'layouts/dtc_bag.json', 'layouts/dtc_bag.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='DTC drive stack maintainers',
    maintainer_email='maintainers@dtc-drive-stack.org',
    description='Recording of the drive graph to rosbag2-layout MCAP bags, bag replay in sim time and replay comparison, and the Foxglove live view.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'recorder = drive_logger.recorder_node:main',
            'replay = drive_logger.replay_node:main',
            'compare_replay = drive_logger.compare_replay:main',
            'reindex = drive_logger.bag_reindex:main',
            'live_view = drive_logger.live_view:main',
            'export = drive_logger.export:main',
        ],
    },
)
