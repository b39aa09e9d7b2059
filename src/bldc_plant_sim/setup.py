from glob import glob

from setuptools import find_packages, setup

package_name = 'bldc_plant_sim'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/motors', glob('motors/*')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='DTC drive stack maintainers',
    maintainer_email='maintainers@dtc-drive-stack.org',
    description='Plant simulator of the DTC drive stack: BLDC/PM motor with non-sinusoidal back-EMF, six- or four-switch inverter, split DC link, boost PFC front end, load machine, sensors and protections; the lockstep time-master plant node.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'plant = bldc_plant_sim.plant_node:main',
            'backemf_generator = bldc_plant_sim.backemf_generator:main',
        ],
    },
)
