"""``ros2 pkg create``: a new ament_python package, upstream ros2pkg's syntax, output and layout
(without its lint tests); ``--template drive_controller`` writes a controller skeleton and a
core test instead of the empty node (docs/write_your_own_controller.md)."""
from __future__ import annotations

import getpass
import os
import re
import shutil
import subprocess
from pathlib import Path

from drive_ros2cli.errors import CliError

BUILD_TYPES = ('cmake', 'ament_cmake', 'ament_python')
TEMPLATES = ('drive_controller',)
CONTROLLER_DEPENDENCIES = ('rclpy', 'drive_common', 'dtc_msgs', 'dtc_controller')
NAME = re.compile(r'^[a-z][a-z0-9_]*$')


def add_arguments(p) -> None:
    p.add_argument('package_name', help='The package name')
    p.add_argument('--package-format', '--package_format', type=int, default=3, choices=[2, 3],
                   help='The package.xml format.')
    p.add_argument('--description', default='TODO: Package description',
                   help='The description given in the package.xml')
    p.add_argument('--license', default='TODO: License declaration',
                   help='The license attached to this package')
    p.add_argument('--destination-directory', default=os.curdir,
                   help='Directory where to create the package directory')
    p.add_argument('--build-type', default='ament_cmake', choices=BUILD_TYPES,
                   help='The build type to process the package with')
    p.add_argument('--dependencies', nargs='+', default=[], help='list of dependencies')
    p.add_argument('--maintainer-email', help='email address of the maintainer of this package')
    p.add_argument('--maintainer-name', default=getpass.getuser(), help='name of the maintainer of this package')
    p.add_argument('--node-name', help='name of the empty executable')
    p.add_argument('--template', choices=TEMPLATES,
                   help='drive_controller: a drive controller skeleton over drive_common.controller_api '
                        '(ament_python; the node is named --node-name, default the package name)')


def _maintainer_email(args) -> str:
    if args.maintainer_email:
        return args.maintainer_email
    git = shutil.which('git')
    if git:
        email = subprocess.run([git, 'config', 'user.email'], capture_output=True, text=True).stdout.strip()
        if email:
            return email
    return f'{args.maintainer_name}@todo.todo'


def package_xml(name: str, fmt: int, description: str, maintainer: str, email: str, license_: str,
                depends: list[str]) -> str:
    """The package.xml of an ament_python package (the only build type created here)."""
    schema = (f'<?xml-model href="http://download.ros.org/schema/package_format{fmt}.xsd" '
              'schematypens="http://www.w3.org/2001/XMLSchema"?>')
    lines = ['<?xml version="1.0"?>', schema, f'<package format="{fmt}">',
             f'  <name>{name}</name>', '  <version>0.0.0</version>',
             f'  <description>{description}</description>',
             f'  <maintainer email="{email}">{maintainer}</maintainer>', f'  <license>{license_}</license>', '']
    if depends:
        lines += [f'  <depend>{d}</depend>' for d in depends] + ['']
    lines += ['  <test_depend>python3-pytest</test_depend>', '', '  <export>',
              '    <build_type>ament_python</build_type>', '  </export>', '</package>', '']
    return '\n'.join(lines)


def setup_py(name: str, node: str | None, maintainer: str, email: str, description: str, license_: str) -> str:
    scripts = f"\n            '{node} = {name}.{node}:main'\n        " if node else ''
    return f"""from setuptools import find_packages, setup

package_name = '{name}'

setup(
    name=package_name,
    version='0.0.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages',
            ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='{maintainer}',
    maintainer_email='{email}',
    description='{description}',
    license='{license_}',
    tests_require=['pytest'],
    entry_points={{
        'console_scripts': [{scripts}],
    }},
)
"""


SETUP_CFG = """[develop]
script_dir=$base/lib/{name}
[install]
install_scripts=$base/lib/{name}
"""

EMPTY_NODE = """def main():
    print('Hi from {name}.')


if __name__ == '__main__':
    main()
"""

CONTROLLER = '''"""{node}: a drive controller over drive_common.controller_api (docs/write_your_own_controller.md).

Six-step (120 deg) commutation from the encoder angle with a one-sided current
chopper: the phase whose back-EMF is most positive is driven +, the most
negative one -, while the pair current is below I* = T* / k_t; above it both
legs open (the diodes freewheel). Replace ``update`` with your own control law.
"""
import math

from drive_common.controller_api import GateSample, ParameterSpec, run_controller, schema
from drive_common.signals import PHASE_SHIFT
from dtc_controller.core.status import DtcStatusSample

SCHEMA = schema([
    ParameterSpec('torque_reference', 0.3, 'electromagnetic torque reference T*', 'N*m', 0.0, 5.0),
    ParameterSpec('torque_constant', 0.2292, 'k_t = T / I with two phases conducting', 'N*m/A', 1e-3, 10.0),
    ParameterSpec('current_limit', 20.0, 'limit of the current reference', 'A', 0.0, 24.0),
])


class Core:
    """ROS-free core: DriveSample of step k -> (GateSample of step k, DtcStatusSample)."""

    SCHEMA = SCHEMA

    def __init__(self, params: dict) -> None:
        self.reconfigure(params)

    def reconfigure(self, params: dict) -> None:
        self.p = SCHEMA.validate_changes(SCHEMA.defaults(), dict(params))

    def update(self, sample):
        p = self.p
        theta = sample.encoder_angle                     # rad, electrical
        emf = [-math.sin(theta - shift) for shift in PHASE_SHIFT]   # back-EMF shape of a, b, c
        plus, minus = emf.index(max(emf)), emf.index(min(emf))
        reference = min(p['current_limit'], p['torque_reference'] / p['torque_constant'])
        current = 0.5 * (sample.phase_current[plus] - sample.phase_current[minus])
        switch_on = [False] * 6                          # SW1/SW2 = a upper/lower, SW3/4 b, SW5/6 c
        if current < reference:
            switch_on[2 * plus] = switch_on[2 * minus + 1] = True
        status = DtcStatusSample.partial(
            sample.step, '{node}', speed_measured=sample.mechanical_speed,
            torque_reference=p['torque_reference'], torque_estimate=p['torque_constant'] * current,
            rotor_angle_estimate=theta, switch_on=tuple(switch_on))
        return GateSample(sample.step, 6, tuple(switch_on)), status


def main(args=None) -> int:
    return run_controller(Core, '{node}', args)


if __name__ == '__main__':
    raise SystemExit(main())
'''

CONTROLLER_TEST = '''"""The core of {node} without ROS: one answer per measurement, same step, a valid gate pattern."""
import math

from drive_common.controller_api import DriveSample, check_core_class

from {name}.{node} import Core


def sample(step, theta, currents=(0.0, 0.0, 0.0)):
    return DriveSample(step, step * 25e-6, currents, 56.57, 28.3, 0, theta, 0, 30.0)


def test_core_answers_each_step_with_one_conducting_pair():
    check_core_class(Core)
    core = Core(Core.SCHEMA.defaults())
    for k, theta in enumerate([0.1, 1.2, 2.3, 3.4, 4.5, 5.6]):
        command, _ = core.update(sample(k, theta))
        assert command.step == k and command.topology == 6
        assert sum(command.switch_on) == 2
        for leg in range(3):
            assert not (command.switch_on[2 * leg] and command.switch_on[2 * leg + 1])


def test_core_opens_the_pair_above_the_reference():
    core = Core(Core.SCHEMA.defaults())
    command, _ = core.update(sample(0, math.radians(60), currents=(-30.0, 30.0, 0.0)))
    assert not any(command.switch_on)
'''


def create_main(args) -> int:
    name = args.package_name
    if not NAME.match(name):
        raise CliError(f"invalid package name '{name}': lower case letters, digits and underscores, "
                       'starting with a letter')
    if args.template and args.build_type != 'ament_python':
        raise CliError(f'--template {args.template} needs --build-type ament_python')
    if args.build_type != 'ament_python':
        raise CliError(f"--build-type {args.build_type}: this embedded ros2 creates ament_python packages "
                       '(use a system ROS 2 for C++ packages)')
    if name == 'test':
        raise CliError("Aborted since 'ament_python' packages can't be named 'test'. Please choose a "
                       'different package name.')
    node = args.node_name or (name if args.template else None)
    if node and not NAME.match(node):
        raise CliError(f"invalid node name '{node}'")
    destination = Path(args.destination_directory)
    root = destination / name
    if root.exists():
        raise CliError('\nAborted!\nThe directory already exists: ' + str(root) + '\nEither remove the '
                       'directory or choose a different destination directory or package name')
    email = _maintainer_email(args)
    depends = list(args.dependencies)
    if args.template:
        depends = [d for d in CONTROLLER_DEPENDENCIES if d not in depends] + depends
    print('going to create a new package')
    print('package name:', name)
    print('destination directory:', destination.resolve())
    print('package format:', args.package_format)
    print('version:', '0.0.0')
    print('description:', args.description)
    print('maintainer:', [f'{args.maintainer_name} <{email}>'])
    print('licenses:', [args.license])
    print('build type:', args.build_type)
    print('dependencies:', depends)
    if node:
        print('node_name:', node)
    if args.template:
        print('template:', args.template)

    def folder(path: Path) -> None:
        print(f'creating folder {_shown(path, destination)}')
        path.mkdir(parents=True)

    def put(path: Path, text: str) -> None:
        print(f'creating {_shown(path, destination)}')
        path.write_text(text)

    folder(root)
    put(root / 'package.xml', package_xml(name, args.package_format, args.description, args.maintainer_name,
                                          email, args.license, depends))
    print('creating source folder')
    folder(root / name)
    put(root / 'setup.py', setup_py(name, node, args.maintainer_name, email, args.description, args.license))
    put(root / 'setup.cfg', SETUP_CFG.format(name=name))
    folder(root / 'resource')
    put(root / 'resource' / name, '')
    put(root / name / '__init__.py', '')
    folder(root / 'test')
    if args.template:
        put(root / 'test' / f'test_{node}.py', CONTROLLER_TEST.format(name=name, node=node))
        put(root / name / f'{node}.py', CONTROLLER.format(node=node))
    elif node:
        put(root / name / f'{node}.py', EMPTY_NODE.format(name=name))
    return 0


def _shown(path: Path, destination: Path) -> str:
    """Upstream prints paths relative to the destination as ./NAME/..."""
    return os.path.join('.', os.path.relpath(path, destination))
