"""The package's own exceptions. The CLI maps every ``GearsweepError`` to one line and exit code 2."""


class GearsweepError(Exception):
    """Base class of every error that is the user's input, not a bug: one clear line, exit 2."""


class StudyError(GearsweepError):
    """A study file that cannot be run: ``file: field.path: value -- what is allowed``."""

    def __init__(self, file: str, field: str, value: object, allowed: str) -> None:
        self.file, self.field, self.value, self.allowed = file, field, value, allowed
        shown = repr(value)
        shown = shown if len(shown) <= 80 else shown[:60] + "..." + shown[-10:]
        line = f"{file}: {field}: {shown} -- {allowed}"
        super().__init__(" ".join(line.splitlines()))  # one line, whatever the parts hold


class GeometryError(GearsweepError):
    """A gear pair that cannot exist (interference, pointed teeth, contact ratio below 1, ...)."""


class ResultError(GearsweepError):
    """A results file that is missing, unreadable, or not a gearsweep result."""


class ClusterError(GearsweepError):
    """A dask cluster that cannot be reached or used, or a chunk that failed on it."""


class LimitError(GearsweepError):
    """A study predicted beyond the time, memory or output limits, not confirmed with --yes."""


class DeviceError(GearsweepError):
    """A compute device asked for (``solver.device: cuda``) that this machine cannot provide, or a
    feature that the device does not run (the kink-aware step on CUDA)."""
