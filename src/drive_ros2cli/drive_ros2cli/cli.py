"""``ros2 <command> <verb> ...``: argparse dispatch to :mod:`drive_ros2cli.verbs`, as upstream ros2cli.

A bad argument prints the usage and exits 2; a :class:`~drive_ros2cli.errors.CliError` prints
its one-line message on stderr and exits 1.
"""
from __future__ import annotations

import argparse
import faulthandler
import importlib
import signal
import sys

from drive_common.cli_output import silence_stdout
from drive_common.node_main import STACK_DUMP_SIGNAL
from drive_ros2cli.errors import CliError

COMMANDS = ('action', 'bag', 'interface', 'node', 'param', 'pkg', 'run', 'service', 'topic')


def _add_command(subparsers, name: str) -> None:
    module = importlib.import_module(f'drive_ros2cli.verbs.{name}')
    parser = subparsers.add_parser(name, help=module.DESCRIPTION, description=module.DESCRIPTION)
    if hasattr(module, 'add_arguments'):          # a command without verbs (run)
        module.add_arguments(parser)
        parser.set_defaults(main=module.main)
        return
    verbs = parser.add_subparsers(title='Commands', dest='verb',
                                  metavar=f'Call `ros2 {name} <command> -h` for more detailed usage.')
    module.add_verbs(verbs)
    parser.set_defaults(main=lambda args, p=parser: _print_help(p))


def _print_help(parser: argparse.ArgumentParser) -> int:
    parser.print_help()
    return 0


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='ros2', description='ros2 is an extensible command-line tool for ROS 2.',
        formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = parser.add_subparsers(title='Commands', dest='command',
                                     metavar='Call `ros2 <command> -h` for more detailed usage.')
    for name in COMMANDS:
        _add_command(commands, name)
    parser.set_defaults(main=lambda args: _print_help(parser))
    return parser


def main(argv=None) -> int:
    parser = make_parser()
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    faulthandler.register(STACK_DUMP_SIGNAL, all_threads=True)   # where a stuck verb hangs
    # Ctrl-C ends a verb even when a non-interactive shell started it with SIGINT ignored
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        return int(args.main(args) or 0)
    except CliError as exc:
        print(exc, file=sys.stderr)
        return exc.code
    except KeyboardInterrupt:
        return int(signal.SIGINT)      # as upstream: Ctrl-C ends a streaming verb with code 2
    except BrokenPipeError:      # the reader went away (`ros2 param list | head`)
        silence_stdout()
        return 0


if __name__ == '__main__':
    raise SystemExit(main())
