"""Running test code where file permissions bind (the tests run as root in CI, which ignores them)."""

from __future__ import annotations

import os


def _drop_permission_override() -> None:
    """Clear CAP_DAC_OVERRIDE and CAP_DAC_READ_SEARCH from this process (Linux ``capset``): root then meets file
    permissions as their owner does, and reads everything it owns (Python's own folders included)."""
    import ctypes

    class Header(ctypes.Structure):
        _fields_ = [("version", ctypes.c_uint32), ("pid", ctypes.c_int)]

    class Data(ctypes.Structure):
        _fields_ = [("effective", ctypes.c_uint32), ("permitted", ctypes.c_uint32), ("inheritable", ctypes.c_uint32)]

    libc = ctypes.CDLL(None, use_errno=True)
    header, data = Header(0x20080522, 0), (Data * 2)()  # _LINUX_CAPABILITY_VERSION_3
    if libc.capget(ctypes.byref(header), data) != 0:
        raise OSError(ctypes.get_errno(), "capget")
    mask = ~((1 << 1) | (1 << 2)) & 0xFFFFFFFF  # CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH
    data[0].effective &= mask
    data[0].permitted &= mask
    if libc.capset(ctypes.byref(header), data) != 0:
        raise OSError(ctypes.get_errno(), "capset")


def as_a_user(fn):
    """``fn()`` where file permissions bind: here, or for root in a child process that has given up its power to
    override them. Returns (exit code, what it wrote to stderr)."""
    import io
    from contextlib import redirect_stderr

    if os.geteuid() != 0:
        err = io.StringIO()
        with redirect_stderr(err):
            code = fn()
        return code, err.getvalue()
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        code = 99
        try:
            os.close(read)
            _drop_permission_override()
            err = io.StringIO()
            with redirect_stderr(err):
                code = fn()
            os.write(write, err.getvalue().encode())
        except BaseException:
            import traceback

            os.write(write, traceback.format_exc().encode())
        finally:
            os._exit(code if isinstance(code, int) else 98)
    os.close(write)
    with os.fdopen(read) as f:
        text = f.read()
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status), text
