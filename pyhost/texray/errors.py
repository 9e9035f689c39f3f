"""Exceptions raised by texray. Every message names the file, field and value at fault."""


class TexrayError(Exception):
    """Base class of texray's errors."""


class SceneError(TexrayError, ValueError):
    """Bad scene input: a file, a field or a value that cannot be rendered."""


class DeviceError(TexrayError, RuntimeError):
    """No usable OpenCL device, or a device that cannot run the scene."""


class BuildError(TexrayError, RuntimeError):
    """An OpenCL program failed to build; the message holds the compiler log."""
