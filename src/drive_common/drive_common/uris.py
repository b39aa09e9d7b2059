"""``package://<pkg>/<path>`` file names: the package's source tree first, else its share directory."""
from __future__ import annotations

from pathlib import Path

SCHEME = 'package://'


def resolve_path(value: str) -> str:
    """A plain path unchanged; ``package://<pkg>/<path>`` -> an absolute path (FileNotFoundError)."""
    if not value.startswith(SCHEME):
        return value
    package, _, rel = value[len(SCHEME):].partition('/')
    if not package or not rel:
        raise FileNotFoundError(f'{value!r} is not package://<package>/<path>')
    source = Path(__file__).resolve().parents[2] / package / rel
    if source.exists():
        return str(source)
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    try:
        return str(Path(get_package_share_directory(package)) / rel)
    except PackageNotFoundError:
        raise FileNotFoundError(f'cannot resolve {value}: no package {package!r}') from None
