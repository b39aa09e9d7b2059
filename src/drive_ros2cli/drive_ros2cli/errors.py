"""The one error type of the ``ros2`` command: a one-line message and an exit code."""


class CliError(RuntimeError):
    """Printed on stderr as is; the command exits with ``code`` (1, as upstream's returned strings)."""

    def __init__(self, message: str, code: int = 1) -> None:
        super().__init__(message)
        self.code = code
