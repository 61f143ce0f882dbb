# The CPython port's groups, kept by the imports (as test_layers.py keeps the
# core's layers). Every module of acomm_cpython belongs to a group: the
# library is its top-level modules (streams, udp, tcp, modems, the asyncio
# library...), the others are its subpackages, named after who uses them.
# A group may import the core (acomm), its own modules and what its row of
# MAY_IMPORT lists; every import counts, lazy ones inside functions too.
# Imports inside the port must not form a cycle. The benchmark workloads
# that also run as scripts under the MicroPython unix port (those with
# PER_RUNTIME figures, and those a workload runs with run_micropython) import
# only acomm, their own folder and MicroPython's built-in modules: there,
# only acomm and that folder are on MICROPYPATH (acomm_cpython.bench.runtime).
# ALLOWED lists the exceptions, each with its reason; it is empty.
import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PORT = os.path.join(ROOT, "ports", "cpython", "acomm_cpython")
WORKLOADS = os.path.join(PORT, "bench", "workloads")

# group -> the groups and packages it may import besides the core and itself
MAY_IMPORT = {
    # shore: a node's link through the Iridium gateway's services, no modem
    # (open_node's iridium=); the library loads it only when asked for one
    "library": {"shore"},
    "shore": {"library"},
    "console": {"library", "acomm_web"},
    "emulate": {"library", "shore", "acomm_sim"},
    "bridges": {"library", "acomm_sim"},
    # demo: its uplink (demo.uplink) runs the emulated gateway's DirectIP and a shore node's link
    "demo": {"library", "shore", "emulate", "acomm_sim", "acomm_web"},
    # acomm_boards: the boards shipped with acomm (package data)
    "board": {"library", "console", "acomm_mp", "acomm_web", "acomm_boards"},
    "bench": {"library", "shore", "board", "demo", "emulate", "bridges", "acomm_sim", "acomm_web", "acomm_mp"},
    "cli": {"library", "shore", "console", "emulate", "bridges", "demo", "board", "bench", "acomm_sim", "acomm_web", "acomm_mp",
            "acomm_boards"},
}
# the packages beside the port whose imports are ruled (others, stdlib and
# third-party, are free)
SIBLINGS = ("acomm_sim", "acomm_web", "acomm_mp", "acomm_boards")
ALLOWED = set()  # (importing module, imported module)

# what a portable workload may import on MicroPython besides acomm and its folder
MICROPYTHON_BUILTINS = {"gc", "sys", "os", "time", "math", "binascii", "micropython", "struct", "array", "io", "json",
                        "errno", "select", "collections", "hashlib", "re", "random", "deflate"}


def modules():
    out = {}
    for d, dirs, files in os.walk(PORT):
        dirs[:] = [x for x in dirs if x != "__pycache__"]
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(d, f)
                rel = "acomm_cpython." + os.path.relpath(path, PORT)[:-3].replace(os.sep, ".")
                out[rel[:-9] if rel.endswith(".__init__") else rel] = path
    return out


def group_of(mod):
    """A module's group: a sibling package's name, "core", the port's group, or None (stdlib, third party)."""
    top = mod.split(".")[0]
    if top == "acomm":
        return "core"
    if top in SIBLINGS:
        return top
    if top != "acomm_cpython":
        return None
    parts = mod.split(".")
    if len(parts) > 1 and os.path.isdir(os.path.join(PORT, parts[1])):
        return parts[1]
    return "library"


def _resolve(node, pkg):
    if node.level:
        base = pkg.split(".")
        base = base[:len(base) - (node.level - 1)]
        return ".".join(base + ([node.module] if node.module else []))
    return node.module


def imports(mod, path, known):
    # -> the modules mod imports; `from X import name` counts X.name when that is a module
    with open(path) as f:
        tree = ast.parse(f.read(), path)
    pkg = mod if path.endswith("__init__.py") else mod.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            src = _resolve(node, pkg)
            out.update(src + "." + a.name if src + "." + a.name in known else src for a in node.names)
    out.discard(mod)
    return out


def graph():
    known = modules()
    return {m: imports(m, p, known) for m, p in known.items()}


def test_every_port_module_has_a_group():
    assert [m for m in modules() if group_of(m) not in MAY_IMPORT] == []


def test_no_group_imports_what_its_row_does_not_list():
    bad = []
    for m, deps in sorted(graph().items()):
        g = group_of(m)
        for d in sorted(deps):
            h = group_of(d)
            if h in (None, "core", g) or h in MAY_IMPORT[g] or (m, d) in ALLOWED:
                continue
            bad.append("%s (%s) imports %s (%s)" % (m, g, d, h))
    assert bad == [], "\n".join(bad)


def test_the_library_imports_neither_the_simulator_nor_the_web_console():
    # the rule above says it; this says it by name, for whoever relaxes a row
    for m, deps in graph().items():
        if group_of(m) == "library":
            assert not [d for d in deps if d.split(".")[0] in ("acomm_sim", "acomm_web")], m


def test_no_import_cycle_in_the_port():
    from test_layers import cycles

    found = cycles(graph(), ALLOWED)
    assert found == [], "\n".join(found)


def test_the_checker_sees_an_upward_import(tmp_path):
    # the rule itself: the library importing a console module or the
    # simulator is caught, lazily too
    p = tmp_path / "x.py"
    p.write_text("def f():\n    from .console.nodeloop import serve\n    import acomm_sim.world\n")
    known = {"acomm_cpython.x": str(p), "acomm_cpython.console.nodeloop": ""}
    deps = imports("acomm_cpython.x", str(p), known)
    assert deps == {"acomm_cpython.console.nodeloop", "acomm_sim.world"}
    assert group_of("acomm_cpython.x") == "library"
    assert [group_of(d) for d in sorted(deps)] == ["console", "acomm_sim"]
    assert "console" not in MAY_IMPORT["library"] and "acomm_sim" not in MAY_IMPORT["library"]


# -- the workloads that run under MicroPython ---------------------------------------


def _tree(name):
    with open(os.path.join(WORKLOADS, name + ".py")) as f:
        return ast.parse(f.read(), name)


def _per_runtime(tree):
    # whether the module says PER_RUNTIME = <something other than ()>
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "PER_RUNTIME" for t in node.targets):
            return not (isinstance(node.value, ast.Tuple) and not node.value.elts)
    return False


def micropython_workloads():
    """The workloads run as MicroPython scripts: PER_RUNTIME ones, and those a workload runs with run_micropython."""
    names = sorted(f[:-3] for f in os.listdir(WORKLOADS) if f.endswith(".py") and f != "__init__.py")
    out = set()
    for n in names:
        tree = _tree(n)
        if _per_runtime(tree):
            out.add(n)
        for node in ast.walk(tree):
            if (isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None)) == "run_micropython"
                    and node.args and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
                out.add(node.args[0].value)
    return sorted(out)


def _guarded(tree):
    # the imports in the body of a try that catches ImportError: on
    # MicroPython they may fail (acomm_cpython is never on its path)
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Try) and any(
                h.type is None or "ImportError" in ast.dump(h.type) for h in node.handlers):
            for stmt in node.body:
                for sub in ast.walk(stmt):
                    if isinstance(sub, (ast.Import, ast.ImportFrom)):
                        out.add(id(sub))
    return out


def micropython_imports(name):
    """[(statement's line, module)] of what workload `name` imports on MicroPython (guarded imports left out)."""
    tree = _tree(name)
    guarded = _guarded(tree)
    out = []
    for node in ast.walk(tree):
        if id(node) in guarded:
            continue
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            out.append((node.lineno, node.module if not node.level else "." * node.level + (node.module or "")))
    return sorted(out)


def test_the_micropython_workloads_import_only_acomm_and_their_folder():
    roots = micropython_workloads()
    # the portable ones the bench measures on both runtimes today
    assert {"core_workload", "queue_workload", "store_workload", "compare_speed"} <= set(roots), roots
    siblings = set(f[:-3] for f in os.listdir(WORKLOADS) if f.endswith(".py"))
    bad, seen, todo = [], set(), list(roots)
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        for line, mod in micropython_imports(name):
            top = mod.split(".")[0]
            if top == "acomm" or mod in MICROPYTHON_BUILTINS:
                continue
            if mod in siblings:
                todo.append(mod)  # its own folder, on MICROPYPATH: what it imports counts too
                continue
            bad.append("%s.py:%d imports %s" % (name, line, mod))
    assert bad == [], "\n".join(bad)


def test_the_micropython_check_sees_a_simulator_import(tmp_path, monkeypatch):
    # the queue workload's old import, which stopped acomm bench queue
    monkeypatch.setitem(globals(), "WORKLOADS", str(tmp_path))
    (tmp_path / "q_workload.py").write_text(
        "try:\n    from acomm_cpython.bench.workloads.timer import rate\nexcept ImportError:\n    from timer import rate\n"
        "from acomm_sim.clock import ManualClock\nPER_RUNTIME = ('x',)\n")
    assert micropython_workloads() == ["q_workload"]
    assert micropython_imports("q_workload") == [(4, "timer"), (5, "acomm_sim.clock")]


def test_setup_cfg_lists_every_package_of_the_port():
    # a subpackage missing from setup.cfg's packages is missing from the wheel
    with open(os.path.join(ROOT, "setup.cfg")) as f:
        text = f.read()
    listed = set(text.split("packages =", 1)[1].split("package_dir", 1)[0].split())
    have = set(m for m, p in modules().items() if p.endswith("__init__.py"))
    assert sorted(have - listed) == []
