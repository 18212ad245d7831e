"""`psychopy.logging` as psychopy-photoresearch uses it: `debug`, `info`,
`warning` and `error` with one message. They go to Python's standard logging
on stderr (level from $PSYCHOPY_LOG, default WARNING), so a failing test shows
what the client said about the instrument.
"""

import logging as _logging
import os as _os

_log = _logging.getLogger("psychopy")
_logging.basicConfig(level=_os.environ.get("PSYCHOPY_LOG", "WARNING"),
                     format="psychopy %(levelname)s: %(message)s")

DEBUG, INFO, WARNING, ERROR = (_logging.DEBUG, _logging.INFO,
                               _logging.WARNING, _logging.ERROR)


def debug(msg):
    _log.debug(msg)


def info(msg):
    _log.info(msg)


def warning(msg):
    _log.warning(msg)


def error(msg):
    _log.error(msg)
