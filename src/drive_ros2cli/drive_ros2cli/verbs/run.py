"""``ros2 run <package> <executable> [argv ...]``: run an installed package executable."""
from __future__ import annotations

import argparse
import os
import shlex
from pathlib import Path

from drive_ros2cli.errors import CliError

DESCRIPTION = 'Run a package specific executable'


def add_arguments(parser) -> None:
    parser.add_argument('--prefix', metavar='PREFIX',
                        help="Prefix command, which should go before the executable (e.g. 'gdb -ex run --args')")
    parser.add_argument('package_name', help='Name of the ROS package')
    parser.add_argument('executable_name', help='Name of the executable')
    parser.add_argument('argv', nargs=argparse.REMAINDER, help='Pass arbitrary arguments to the executable')


def package_prefix(package: str) -> Path:
    from ament_index_python.packages import PackageNotFoundError, get_package_prefix
    try:
        return Path(get_package_prefix(package))
    except PackageNotFoundError:
        raise CliError(f"Package '{package}' not found") from None


def executables(package: str) -> list[Path]:
    """Executable files of lib/<package> (what ros2 run can start), sorted."""
    directory = package_prefix(package) / 'lib' / package
    if not directory.is_dir():
        return []
    return sorted(p for p in directory.iterdir() if p.is_file() and os.access(p, os.X_OK))


def main(args) -> int:
    matches = [p for p in executables(args.package_name) if p.name == args.executable_name]
    if not matches:
        raise CliError('No executable found')
    command = [*shlex.split(args.prefix or ''), str(matches[0]), *args.argv]
    os.execvp(command[0], command)   # the node gets the terminal and the signals, as with ros2 run
    return 0
