"""``ros2 pkg create|list|executables``: new packages (drive_ros2cli.pkg_create), the ament index's packages and their executables."""
from __future__ import annotations

from drive_ros2cli import pkg_create
from drive_ros2cli.verbs.run import executables, package_prefix
from drive_ros2cli.verbs import add_verb

DESCRIPTION = 'Various package related sub-commands'


def add_verbs(verbs) -> None:
    p = add_verb(verbs, 'create', pkg_create.create_main, 'Create a new ROS 2 package')
    pkg_create.add_arguments(p)
    add_verb(verbs, 'list', list_main, 'Output a list of available packages')
    p = add_verb(verbs, 'executables', executables_main, 'Output a list of package specific executables')
    p.add_argument('package_name', nargs='?', help='Name of the ROS package')
    p.add_argument('--full-path', action='store_true', help='Show the full path of each executable')


def _packages() -> list[str]:
    from ament_index_python.packages import get_packages_with_prefixes
    return sorted(get_packages_with_prefixes())


def list_main(args) -> int:
    for name in _packages():
        print(name)
    return 0


def executables_main(args) -> int:
    packages = [args.package_name] if args.package_name else _packages()
    if args.package_name:
        package_prefix(args.package_name)        # unknown package: error
    for package in packages:
        for path in executables(package):
            print(path if args.full_path else f'{package} {path.name}')
    return 0
