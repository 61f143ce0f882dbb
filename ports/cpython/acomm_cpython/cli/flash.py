# `acomm flash --board NAME --port DEVICE`: the front end of
# acomm_cpython.board.flash, which copies a board's program to a MicroPython
# board with mpremote; exit 2 for a usage or board error, 1 when the copy fails.
import sys

from ..board.flash import FlashError, run


def add_arguments(p):
    p.add_argument("--board", required=True, help="board name: a folder under --boards with main.py and config.py")
    p.add_argument("--port", metavar="DEVICE", help="the board's serial device (e.g. /dev/ttyACM0); "
                                                    "not needed with --dry-run")
    p.add_argument("--dry-run", action="store_true", help="list the device paths and sizes, copy nothing")
    p.add_argument("--no-compile", action="store_true", help="copy the modules as .py source instead of .mpy")
    p.add_argument("--arch", help="mpy-cross -march (default: the config's \"arch\")")
    p.add_argument("--boards", metavar="DIR", help="folder of boards (default: boards/ in the repository)")
    p.add_argument("--frozen", action="store_true",
                   help="the board's firmware has acomm frozen in: copy only main.py and config.py, and stop if "
                        "the board has no frozen acomm (without it this is found out on the board)")
    p.add_argument("--force", action="store_true",
                   help="flash even when the board's frozen acomm has another version than this host's")
    p.add_argument("--reset", action="store_true",
                   help="hard-reset the board once the files are copied, so its main.py starts")


def main(args):
    try:
        return run(args)
    except FlashError as e:
        sys.stderr.write("acomm flash: %s\n" % e)
        return e.status
