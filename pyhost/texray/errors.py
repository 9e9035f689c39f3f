"""Exceptions raised by texray, and the scene cache's warning. Every message names the file, field
and value at fault."""


class TexrayError(Exception):
    """Base class of texray's errors."""


class SceneError(TexrayError, ValueError):
    """Bad scene input: a file, a field or a value that cannot be rendered."""


class DeviceError(TexrayError, RuntimeError):
    """No usable OpenCL device, or a device that cannot run the scene."""


class BuildError(TexrayError, RuntimeError):
    """An OpenCL program failed to build; the message holds the compiler log."""


class CacheError(TexrayError, ValueError):
    """A bad setting of the scene cache (texray.compile.cache): the variable and its value."""


class CacheWarning(UserWarning):
    """The scene cache could not read or write a file; the render went on without it."""
