"""fmpy's logger proxy, kept from pointing at a freed callback.

fmpy formats an FMU's printf-style messages in C (``fmpy/logging``: ``addLoggerProxy``) and hands
the text to ONE process-wide Python callback: registering a logger (``simulate_fmu(logger=...)``,
or :meth:`harness.fmi.instance.Instance.instantiate` with ``format_messages``) replaces it for
every FMU of the process, fmpy's default callbacks included. When that logger's ctypes callback is
freed (the run is over), the next FMU that logs through fmpy's default callbacks calls freed
memory: the process dies with SIGSEGV or SIGFPE inside fmpy's ``logMessage`` (measured with
fmpy 0.3: ``simulate_fmu(f, logger=lambda *a: None, debug_logging=True)``, then any run of an FMU
that logs at start-up with the default logger). :func:`use_proxy` keeps every callback it
registers alive for the life of the process; :func:`restore_default` points the proxy back at
fmpy's own ``printLogMessage`` (kept alive here), which the harness does when such an instance is
freed and the tests do after each test.
"""
from __future__ import annotations

from ctypes import byref

_KEPT: list = []         # every callback structure the proxy has pointed into: never freed
_DEFAULT = None


def use_proxy(callbacks) -> bool:
    """Let fmpy format messages before ``callbacks.logger`` sees them (``callbacks``: an
    ``fmi2CallbackFunctions``); False where fmpy has no proxy library."""
    try:
        from fmpy.logging import addLoggerProxy
    except Exception:
        return False
    _KEPT.append((callbacks, callbacks.logger))
    addLoggerProxy(byref(callbacks))
    return True


def restore_default() -> None:
    """Point fmpy's proxy back at its default printer (``fmpy.printLogMessage``)."""
    global _DEFAULT
    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, printLogMessage
    try:
        from fmpy.logging import addLoggerProxy
    except Exception:           # no proxy library for this platform: nothing points anywhere
        return
    if _DEFAULT is None:
        _DEFAULT = (fmi2CallbackFunctions(), fmi2CallbackFunctions())
        _DEFAULT[0].logger = fmi2CallbackLoggerTYPE(printLogMessage)   # owns the trampoline
        _KEPT.append(_DEFAULT)
    keeper, given = _DEFAULT
    given.logger = keeper.logger        # addLoggerProxy rewrites the structure it is given
    addLoggerProxy(byref(given))
