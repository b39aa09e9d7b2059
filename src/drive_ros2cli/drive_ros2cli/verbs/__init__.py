"""One module per ``ros2`` command; each has ``DESCRIPTION`` and ``add_verbs(subparsers)``."""


def add_verb(verbs, name: str, main, text: str, description: str | None = None, graph: bool = False):
    """The parser of a verb as upstream's: ``text`` its help (and description unless given), the
    graph options of drive_ros2cli.client.add_node_arguments with ``graph``, ``main`` its entry."""
    p = verbs.add_parser(name, help=text, description=text if description is None else description)
    if graph:
        from drive_ros2cli.client import add_node_arguments
        add_node_arguments(p)
    p.set_defaults(main=main)
    return p
