#!/usr/bin/env python3
# Builds MicroPython firmware with acomm frozen in, into build/firmware/:
#
#   cm3-plain.elf   qemu MPS2-AN385 (Cortex-M3), a filesystem and no acomm:
#                   the board `acomm flash` copies modules to
#   cm3-buoy.elf    the same with the buoy's import closure frozen
#                   (ports/micropython/manifests/buoy_pico.py): how a
#                   production buoy is built; flash_text_bytes compares it
#                   with cm3-plain
#   cm3-full.elf    every module of acomm and acomm_mp frozen, and the
#                   footprint harness (tools/lockstep/): the core suite and
#                   the frozen heap figures run on it
#   cm3-harness.elf cm3-plain with only the footprint harness frozen: the
#                   ROMFS and .mpy heap figures run the buoy's files on it,
#                   so that they count the buoy and not the harness
#   cm3-names.elf   cm3-harness with the buoy's names frozen too (a module
#                   that names them, never imported: tools/qstrnames.py): a
#                   firmware made for a buoy that runs its modules from
#                   ROMFS, whose names then cost no RAM
#   micropython-i386  the unix port built for i386 (-m32), full manifest
#   rp2040-stock.uf2  MicroPython's own RPI_PICO firmware (the board's own
#                   manifest, what a user downloads): `acomm flash` copies
#                   the buoy's .mpy files to it
#   buoy_pico.uf2   the same with the buoy's import closure frozen in
#                   (ports/micropython/manifests/buoy_pico.py, which extends
#                   the board's manifest): the Pico's production image
#   rp2040-full.uf2 every module of acomm and acomm_mp and the footprint
#                   harness frozen: the core suite and the frozen heap
#                   figures run on it in the RP2040 emulator
#                   (each rp2040 product also leaves its .elf beside it)
#   mpy-cross       the matching cross compiler
#
#   python3 tools/firmware.py build [--only NAME]   build what is stale
#   python3 tools/firmware.py check                 exit 0 when a build can
#                   run here, else print one line saying what is missing
#
# The MicroPython source, one release for every product: $MPY_DIR (a
# checkout of micropython/micropython at v1.28.0 with the submodules rp2
# needs: lib/pico-sdk, lib/tinyusb, lib/micropython-lib), else the v1.28.0
# tarball in ../shared/vendor/ next to the repository (or $ACOMM_SHARED/vendor),
# else a shallow git clone of v1.28.0 and those submodules where the network
# allows it. The build never writes into that tree: it makes a shadow tree
# in build/mpy-src/ (links to py/, extmod/, shared/, lib/, tools/; copies of
# mpy-cross/ and the three ports) and applies the project's patch
# (ports/micropython/firmware/qemu-mps2.patch) to its copy of the qemu port.
# The rp2 port is not patched: the Pico runs MicroPython's own code.
#
# Each product is rebuilt only when its key changes: a hash of the
# MicroPython source's identity and of every file that goes into it.
# The Debian packages the builds need are installed with apt-get when they
# are missing and this runs as root; otherwise it says which to install.
import argparse
import glob
import hashlib
import os
import shutil
import subprocess
import sys
import tarfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUILD = os.path.join(ROOT, "build")
OUT = os.path.join(BUILD, "firmware")
FW = os.path.join(ROOT, "ports", "micropython", "firmware")
PATCH = os.path.join(FW, "qemu-mps2.patch")
TESTED = "v1.28.0"
GIT_URL = "https://github.com/micropython/micropython"
# the release's own tarball in shared/vendor (with the submodules rp2 pins)
VENDOR_GLOB = "micropython-v1.28.0*.tar.gz"
RP2_SUBMODULES = ("lib/pico-sdk", "lib/tinyusb", "lib/micropython-lib")
# The largest heap the qemu builds can be given; a smaller one is set at
# boot (ports/micropython/firmware/qemu-mps2.patch), so one build serves
# the test suite (big heap) and the footprint bisection (small ones).
QEMU_HEAP = 2 * 1024 * 1024
JOBS = str(max(2, os.cpu_count() or 2))

# name -> (port, manifest parts); parts: "boot" (the qemu board's
# _boot.py), "asyncio", "full" (ports/micropython/manifest.py), "harness"
# (tools/lockstep), "board:NAME" (ports/micropython/manifests/NAME.py), or
# "names:BOARD" (the names the modules of boards/BOARD use, tools/qstrnames.py)
PRODUCTS = {
    "cm3-plain": ("qemu", ("boot", "asyncio")),
    "cm3-buoy": ("qemu", ("boot", "board:buoy_pico")),
    "cm3-full": ("qemu", ("boot", "full", "harness")),
    "cm3-harness": ("qemu", ("boot", "asyncio", "harness")),
    "cm3-names": ("qemu", ("boot", "asyncio", "harness", "names:buoy_pico")),
    "micropython-i386": ("unix", ("full", "harness")),
    "rp2040-stock": ("rp2", ("rp2port",)),
    "buoy_pico": ("rp2", ("board:buoy_pico",)),
    "rp2040-full": ("rp2", ("full", "harness")),
}
# what a product leaves in build/firmware/, by port
SUFFIX = {"qemu": ".elf", "unix": "", "rp2": ".uf2"}


class Missing(Exception):
    """What a build here lacks, in one line that says how to get it."""


def say(msg):
    print("firmware: " + msg, flush=True)


# --- the MicroPython source ---------------------------------------------------


def _vendor_tarball():
    for d in (os.environ.get("ACOMM_SHARED"), os.path.join(os.path.dirname(ROOT), "shared")):
        if d:
            hits = sorted(glob.glob(os.path.join(d, "vendor", VENDOR_GLOB)))
            if hits:
                return hits[-1]
    return None


def _sha(path, h=None):
    h = h or hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 16), b""):
            h.update(chunk)
    return h


def source():
    """(root of a MicroPython tree, identity string); Missing when none can be had."""
    mpy = os.environ.get("MPY_DIR")
    if mpy:
        mpy = os.path.abspath(mpy)
        if not os.path.isfile(os.path.join(mpy, "py", "mpconfig.h")):
            raise Missing("MPY_DIR=%s is not a MicroPython source tree (no py/mpconfig.h)" % mpy)
        head = ""
        try:
            head = subprocess.run(["git", "-C", mpy, "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
        except OSError:
            pass
        return mpy, "dir:%s:%s:%s" % (mpy, head, _sha(os.path.join(mpy, "py", "mpconfig.h")).hexdigest())
    tar = _vendor_tarball()
    if tar:
        digest = _sha(tar).hexdigest()
        dest = os.path.join(BUILD, "mpy-src", "vendor-" + digest[:12])
        if not os.path.isfile(os.path.join(dest, "micropython", "py", "mpconfig.h")):
            say("unpacking %s" % os.path.basename(tar))
            shutil.rmtree(dest, ignore_errors=True)
            os.makedirs(dest)
            with tarfile.open(tar) as t:
                t.extractall(dest)
        return os.path.join(dest, "micropython"), "tar:" + digest
    dest = os.path.join(BUILD, "mpy-src", "git")
    if not os.path.isfile(os.path.join(dest, "py", "mpconfig.h")):
        if shutil.which("git") is None:
            raise Missing("no MicroPython source: set MPY_DIR to a checkout of %s" % GIT_URL)
        say("cloning %s %s (no MPY_DIR, no vendored tarball)" % (GIT_URL, TESTED))
        shutil.rmtree(dest, ignore_errors=True)
        r = subprocess.run(["git", "clone", "-q", "--depth", "1", "--branch", TESTED, GIT_URL, dest],
                           capture_output=True, text=True, timeout=300)
        if r.returncode == 0:
            r = subprocess.run(["git", "-C", dest, "submodule", "update", "-q", "--init", "--depth", "1"]
                               + list(RP2_SUBMODULES), capture_output=True, text=True, timeout=900)
        if r.returncode != 0:
            shutil.rmtree(dest, ignore_errors=True)
            raise Missing("no MicroPython source: set MPY_DIR to a checkout of %s (cloning it failed: %s)"
                          % (GIT_URL, (r.stderr.strip().splitlines() or ["?"])[-1]))
    head = subprocess.run(["git", "-C", dest, "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    return dest, "git:" + head


def shadow(src, ident):
    """A tree in build/ to build in: links to src's shared parts, copies of what is built or patched."""
    key = hashlib.sha256((ident + _sha(PATCH).hexdigest()).encode()).hexdigest()[:12]
    dest = os.path.join(BUILD, "mpy-src", "tree-" + key)
    stamp = os.path.join(dest, ".patched")
    if os.path.exists(stamp):
        return dest
    shutil.rmtree(dest, ignore_errors=True)
    os.makedirs(os.path.join(dest, "ports"))
    for d in ("py", "extmod", "shared", "lib", "tools", "drivers"):
        if os.path.exists(os.path.join(src, d)):
            os.symlink(os.path.join(src, d), os.path.join(dest, d))
    ign = shutil.ignore_patterns("build", "build-*")
    shutil.copytree(os.path.join(src, "mpy-cross"), os.path.join(dest, "mpy-cross"), ignore=ign, symlinks=True)
    for port in ("qemu", "unix", "rp2"):
        if port == "rp2" and not os.path.isdir(os.path.join(src, "ports", port)):
            continue  # said by build_rp2, which needs it
        shutil.copytree(os.path.join(src, "ports", port), os.path.join(dest, "ports", port), ignore=ign, symlinks=True)
    r = subprocess.run(["patch", "-p1", "-s", "-N", "-d", os.path.join(dest, "ports"), "-i", PATCH],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise Missing("%s does not apply to the MicroPython source at %s (tested with %s): %s"
                      % (os.path.relpath(PATCH, ROOT), src, TESTED, (r.stdout + r.stderr).strip()[:300]))
    open(stamp, "w").close()
    return dest


# --- tools --------------------------------------------------------------------


def _missing_tools():
    miss = []
    # Debian's gcc-arm-none-eabi does not pull in its C library: without
    # the compiler, newlib is missing too (asking only for the compiler
    # left a fresh machine, and CI, with no libc.a and no firmware).
    if shutil.which("arm-none-eabi-gcc") is None:
        # all three: without the C++ library the check below finds it missing after the install
        miss += ["gcc-arm-none-eabi", "libnewlib-arm-none-eabi", "libstdc++-arm-none-eabi-newlib"]
    else:
        libc = subprocess.run(["arm-none-eabi-gcc", "-print-file-name=libc.a"], capture_output=True, text=True).stdout
        if not os.path.isabs(libc.strip()):
            miss.append("libnewlib-arm-none-eabi")
        # the pico-sdk has C++ parts (rp2 builds)
        cxx = subprocess.run(["arm-none-eabi-gcc", "-print-file-name=libstdc++.a"], capture_output=True,
                             text=True).stdout
        if not os.path.isabs(cxx.strip()):
            miss.append("libstdc++-arm-none-eabi-newlib")
    if shutil.which("qemu-system-arm") is None:
        miss.append("qemu-system-arm")
    if not glob.glob("/usr/lib/gcc/*/*/32/libgcc.a"):
        miss.append("gcc-multilib")
    for tool, pkg in (("make", "make"), ("gcc", "gcc"), ("patch", "patch"), ("cmake", "cmake")):
        if shutil.which(tool) is None:
            miss.append(pkg)
    return miss


def ensure_tools(install=True):
    """Installs the missing Debian packages when root can; Missing says which otherwise."""
    miss = _missing_tools()
    if not miss:
        return
    can = install and hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("apt-get")
    if not can:
        raise Missing("missing %s: run 'apt-get install %s' as root" % (", ".join(miss), " ".join(miss)))
    say("installing %s" % " ".join(miss))
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    cmd = ["apt-get", "install", "-y", "-q", "--no-install-recommends"] + miss
    if subprocess.run(cmd, env=env, capture_output=True).returncode != 0:
        subprocess.run(["apt-get", "update", "-q"], env=env, capture_output=True)
        r = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if r.returncode != 0:
            raise Missing("apt-get install %s failed: %s" % (" ".join(miss), (r.stderr.strip().splitlines() or ["?"])[-1]))
    still = _missing_tools()
    if still:
        raise Missing("still missing after apt-get: %s" % ", ".join(still))


# --- manifests and keys -------------------------------------------------------


def _manifest(parts, work):
    lines = ["# generated by tools/firmware.py for one product; do not edit"]
    for p in parts:
        if p == "boot":
            lines.append("freeze(%r, %r)" % (FW, "_boot.py"))
        elif p == "rp2port":
            # exactly what MicroPython's own RPI_PICO firmware freezes
            lines.append('include("$(PORT_DIR)/boards/manifest.py")')
        elif p == "asyncio":
            lines.append('include("$(MPY_DIR)/extmod/asyncio")')
        elif p == "full":
            lines.append("include(%r)" % os.path.join(ROOT, "ports", "micropython", "manifest.py"))
        elif p == "harness":
            lines.append("freeze(%r, %r)" % (os.path.join(ROOT, "tools", "lockstep"), "acomm_lockstep.py"))
        elif p.startswith("board:"):
            lines.append("include(%r)" % os.path.join(ROOT, "ports", "micropython", "manifests", p[6:] + ".py"))
        elif p.startswith("names:"):
            sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
            import qstrnames

            names = qstrnames.board_names(qstrnames.board_files(p[6:]), os.path.join(OUT, "mpy-cross"))
            with open(os.path.join(work, "acomm_names.py"), "w") as f:
                f.write(qstrnames.names_module(names))
            lines.append("freeze(%r, %r)" % (work, "acomm_names.py"))
        else:
            raise ValueError(p)
    return "\n".join(lines) + "\n"


def _inputs():
    # every file whose change must rebuild a product (coarse on purpose: a
    # few seconds of build beat a stale firmware)
    out = [os.path.abspath(__file__), os.path.join(ROOT, "tools", "qstrnames.py"), PATCH]
    for base in (os.path.join(ROOT, "acomm"), os.path.join(ROOT, "ports", "micropython"), os.path.join(ROOT, "tools", "lockstep")):
        for dirpath, dirnames, filenames in os.walk(base):
            dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
            out.extend(os.path.join(dirpath, f) for f in sorted(filenames) if f.endswith((".py", ".patch")))
    return out


def key(ident):
    h = hashlib.sha256(ident.encode())
    for p in _inputs():
        h.update(os.path.relpath(p, ROOT).encode())
        _sha(p, h)
    return h.hexdigest()


def _out(name):
    return os.path.join(OUT, name + (SUFFIX[PRODUCTS[name][0]] if name in PRODUCTS else ""))


def _fresh(name, k):
    path = os.path.join(OUT, name + ".key")
    try:
        with open(path) as f:
            return f.read().strip() == k and os.path.exists(_out(name))
    except OSError:
        return False


def _run(cmd, log):
    # MicroPython's makeversionhdr.py asks git for the version: the tree is
    # under build/ in this repository, so git would answer with acomm's
    # commit; above build/mpy-src it finds nothing and takes mpconfig.h's
    # (v1.28.0)
    env = dict(os.environ, GIT_CEILING_DIRECTORIES=os.path.join(BUILD, "mpy-src"))
    with open(log, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, env=env)
    if r.returncode != 0:
        with open(log) as f:
            tail = f.read().splitlines()[-25:]
        raise RuntimeError("%s failed (log %s):\n%s" % (" ".join(cmd[:4]), log, "\n".join(tail)))


# --- the builds ---------------------------------------------------------------


def _make_common(tree, name, parts):
    work = os.path.join(OUT, "work", name)
    os.makedirs(work, exist_ok=True)
    man = os.path.join(work, "manifest.py")
    with open(man, "w") as f:
        f.write(_manifest(parts, work))
    # py/manifest.mk wants $(MPY_LIB_DIR)/README.md (micropython-lib) even
    # when nothing require()s from it; the port-dir manifest stands in for
    # $(PORT_DIR)/boards/manifest.py, which only some ports have
    return work, ["FROZEN_MANIFEST=" + man, "MPY_LIB_DIR=" + FW, "MICROPY_MANIFEST_PORT_DIR=" + os.path.join(FW, "port"),
                  "BUILD=" + os.path.join(work, "build")]


def build_mpy_cross(tree):
    _run(["make", "-C", os.path.join(tree, "mpy-cross"), "-j" + JOBS], os.path.join(OUT, "mpy-cross.log"))
    shutil.copyfile(os.path.join(tree, "mpy-cross", "build", "mpy-cross"), os.path.join(OUT, "mpy-cross"))
    os.chmod(os.path.join(OUT, "mpy-cross"), 0o755)


def _seed_qemu_build(work, k):
    # The qemu products differ only in what they freeze: a product's build
    # folder starts as a copy of one built from the same sources (its key
    # is this build's), times kept, so make compiles only the frozen code
    # again (about 20 s each instead of a whole build). frozen_content.c
    # goes, as in build_rp2. From an older key nothing is copied: its
    # objects' dependency files name another tree.
    dest = os.path.join(work, "build")
    if k is None or os.path.isdir(dest):
        return
    for other, (port, _) in PRODUCTS.items():
        src = os.path.join(OUT, "work", other, "build")
        if port == "qemu" and _fresh(other, k) and os.path.isfile(os.path.join(src, "firmware.elf")):
            shutil.copytree(src, dest, symlinks=True)
            os.remove(os.path.join(dest, "frozen_content.c"))
            return


def build_qemu(tree, name, parts, k=None):
    work, args = _make_common(tree, name, parts)
    _seed_qemu_build(work, k)
    cmd = ["make", "-C", os.path.join(tree, "ports", "qemu"), "-j" + JOBS, "BOARD=MPS2_AN385",
           "MICROPY_VFS_LFS2=1", "MICROPY_HEAP_SIZE=%d" % QEMU_HEAP,
           # asyncio as on a board; 1-byte qstr hashes as rp2 has them
           "CFLAGS_EXTRA=-DMICROPY_PY_ASYNCIO=1 -DMICROPY_QSTR_BYTES_IN_HASH=1 -DMICROPY_STACK_SIZE=16384"] + args
    _run(cmd, os.path.join(work, "make.log"))
    shutil.copyfile(os.path.join(work, "build", "firmware.elf"), os.path.join(OUT, name + ".elf"))


def build_unix32(tree, name, parts, k=None):
    work, args = _make_common(tree, name, parts)
    cmd = ["make", "-C", os.path.join(tree, "ports", "unix"), "-j" + JOBS, "VARIANT=standard",
           "CFLAGS_EXTRA=-m32", "LDFLAGS_EXTRA=-m32", "MPY_CROSS_FLAGS=-march=x86",
           # these need git submodules the source subset does not carry
           "MICROPY_PY_BTREE=0", "MICROPY_PY_FFI=0", "MICROPY_PY_SSL=0", "MICROPY_USE_READLINE=0"] + args
    _run(cmd, os.path.join(work, "make.log"))
    shutil.copyfile(os.path.join(work, "build", "micropython"), os.path.join(OUT, name))
    os.chmod(os.path.join(OUT, name), 0o755)


def build_rp2(tree, name, parts, k=None):
    # One CMake build folder serves every rp2 product: the C objects are the
    # same, so after the first product only the frozen code is compiled
    # again (makemanifest.py keeps frozen_content.c while its inputs are
    # older than it, whatever the manifest: hence the delete). picotool is
    # not used (the SDK would download it): tools/uf2.py writes the UF2.
    port = os.path.join(tree, "ports", "rp2")
    if not os.path.isfile(os.path.join(tree, "lib", "pico-sdk", "README.md")):
        raise Missing("the MicroPython source has no lib/pico-sdk (rp2 needs %s: git submodule update --init %s)"
                      % (", ".join(RP2_SUBMODULES), " ".join(RP2_SUBMODULES)))
    work, _ = _make_common(tree, name, parts)
    bdir = os.path.join(OUT, "work", "rp2-RPI_PICO")
    log = os.path.join(work, "make.log")
    _run(["cmake", "-S", port, "-B", bdir, "-DPICO_BUILD_DOCS=0", "-DMICROPY_BOARD=RPI_PICO",
          "-DMICROPY_BOARD_DIR=" + os.path.join(port, "boards", "RPI_PICO"), "-DPICO_NO_PICOTOOL=1",
          "-DMICROPY_FROZEN_MANIFEST=" + os.path.join(work, "manifest.py")], os.path.join(work, "cmake.log"))
    try:
        os.remove(os.path.join(bdir, "frozen_content.c"))
    except OSError:
        pass
    _run(["make", "-C", bdir, "-j" + JOBS], log)
    shutil.copyfile(os.path.join(bdir, "firmware.elf"), os.path.join(OUT, name + ".elf"))
    # kept per product, as the other ports' builds keep theirs (the folder
    # is shared): what each image froze is read from it
    os.makedirs(os.path.join(work, "build"), exist_ok=True)
    shutil.copyfile(os.path.join(bdir, "frozen_content.c"), os.path.join(work, "build", "frozen_content.c"))
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import uf2

    with open(os.path.join(bdir, "firmware.bin"), "rb") as f:
        image = f.read()
    with open(_out(name) + ".tmp", "wb") as f:
        f.write(uf2.write(image))
    os.replace(_out(name) + ".tmp", _out(name))


# each is called (tree, name, parts, k): k, this build's key, lets a qemu
# product start from a sibling's folder (the rp2 products share one anyway)
BUILDERS = {"qemu": build_qemu, "unix": build_unix32, "rp2": build_rp2}


def build(only=None, install=True):
    """Builds every stale product (or only those named); Missing when it cannot run here."""
    ensure_tools(install)
    src, ident = source()
    tree = shadow(src, ident)
    os.makedirs(OUT, exist_ok=True)
    k = key(ident)
    with open(os.path.join(OUT, "SOURCE"), "w") as f:
        f.write(ident + "\n")
    if not _fresh("mpy-cross", k):
        say("building mpy-cross")
        build_mpy_cross(tree)
        with open(os.path.join(OUT, "mpy-cross.key"), "w") as f:
            f.write(k)
    for name, (port, parts) in PRODUCTS.items():
        if only and name not in only:
            continue
        if _fresh(name, k):
            continue
        say("building %s" % name)
        BUILDERS[port](tree, name, parts, k)
        with open(os.path.join(OUT, name + ".key"), "w") as f:
            f.write(k)
    return OUT


def product(name):
    """Path of a built product, or None when it is not built for the current sources."""
    path = _out(name) if name in PRODUCTS else os.path.join(OUT, name)
    return path if os.path.exists(path) else None


def main(argv=None):
    p = argparse.ArgumentParser(description="build MicroPython firmware with acomm frozen in (build/firmware/)")
    p.add_argument("what", choices=("build", "check"))
    p.add_argument("--only", action="append", choices=sorted(PRODUCTS), help="build only this product (repeatable)")
    p.add_argument("--no-install", action="store_true", help="never run apt-get; say what is missing instead")
    a = p.parse_args(argv)
    try:
        if a.what == "check":
            miss = _missing_tools()
            can_install = hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("apt-get")
            if miss and (a.no_install or not can_install):
                raise Missing("missing %s: run 'apt-get install %s' as root" % (", ".join(miss), " ".join(miss)))
            if not os.environ.get("MPY_DIR") and not _vendor_tarball() and not os.path.exists(os.path.join(BUILD, "mpy-src", "git")):
                raise Missing("no MicroPython source: set MPY_DIR to a checkout of %s" % GIT_URL)
            return 0
        build(a.only, install=not a.no_install)
    except Missing as e:
        say(str(e))
        return 3
    except RuntimeError as e:
        say(str(e))
        return 1
    say("built in %s" % os.path.relpath(OUT, os.getcwd()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
