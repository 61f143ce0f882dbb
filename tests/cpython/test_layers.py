# The layers of DESIGN.md, kept by the imports: every module of acomm/ is
# given its layer by its folder, and every import in it (lazy ones inside
# functions included) must point at its own layer or one below. Imports
# inside one layer may go either way but must not form a cycle. ALLOWED
# lists the exceptions, each with its reason; it is empty, and a change that
# needs an entry should rather inject what it needs from above. The
# simulator (ports/sim/acomm_sim) has no layers, but is kept free of cycles.
import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CORE = os.path.join(ROOT, "acomm")
SIM = os.path.join(ROOT, "ports", "sim", "acomm_sim")  # no layers, but no cycles either

# lowest first; a module's layer is the first prefix that names it
LAYERS = (
    ("compat", ("acomm", "acomm.compat", "acomm.errors", "acomm.events", "acomm.prng")),
    ("codec", ("acomm.codec", "acomm.imc")),
    ("frame", ("acomm.frame",)),
    ("driver", ("acomm.drivers",)),
    ("link", ("acomm.link",)),
    ("transport", ("acomm.transport",)),
    ("node", ("acomm.node",)),
    ("apps", ("acomm.apps", "acomm.catalog")),
)
ALLOWED = set()  # (importing module, imported module)


def layer_of(mod):
    best = None
    for i, (_, prefixes) in enumerate(LAYERS):
        for p in prefixes:
            if (mod == p or mod.startswith(p + ".")) and (best is None or len(p) > best[1]):
                best = (i, len(p))
    return None if best is None else best[0]


def modules(top=CORE):
    out = {}
    for d, _, files in os.walk(top):
        for f in files:
            if f.endswith(".py"):
                path = os.path.join(d, f)
                rel = os.path.relpath(path, os.path.dirname(top))[:-3].replace(os.sep, ".")
                out[rel[:-9] if rel.endswith(".__init__") else rel] = path
    return out


def imports(mod, path, known, pkg_name="acomm"):
    # -> the modules of package pkg_name that mod imports; `from X import name` counts X.name when that is a module
    with open(path) as f:
        tree = ast.parse(f.read(), path)
    pkg = mod if path.endswith("__init__.py") else mod.rpartition(".")[0]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")
                base = base[:len(base) - (node.level - 1)]
                src = ".".join(base + ([node.module] if node.module else []))
            else:
                src = node.module
            names = [src + "." + a.name if src + "." + a.name in known else src for a in node.names]
        else:
            continue
        for n in names:
            if n == pkg_name or n.startswith(pkg_name + "."):
                out.add(n if n in known else n.rpartition(".")[0] if n.rpartition(".")[0] in known else n)
    out.discard(mod)
    return out


def graph(top=CORE):
    known = modules(top)
    name = os.path.basename(top)
    return {m: imports(m, p, known, name) for m, p in known.items()}


def test_every_core_module_has_a_layer():
    assert [m for m in modules() if layer_of(m) is None] == []


def test_no_import_points_up_the_layers():
    up = []
    for m, deps in sorted(graph().items()):
        for d in sorted(deps):
            if layer_of(d) > layer_of(m) and (m, d) not in ALLOWED:
                up.append("%s (%s) imports %s (%s)" % (m, LAYERS[layer_of(m)][0], d, LAYERS[layer_of(d)][0]))
    assert up == [], "\n".join(up)


def test_no_import_cycle():
    found = cycles(graph())
    assert found == [], "\n".join(found)


def test_no_import_cycle_in_the_simulator():
    # acomm_sim has no layers, but a cycle there (its fuzz engine and
    # targets importing each other, until fuzz_base) is still a tangle
    g = graph(SIM)
    assert "acomm_sim.fuzz_base" in g and "acomm_sim.world" in g
    found = cycles(g)
    assert found == [], "\n".join(found)


def cycles(g, allowed=None):
    """The import cycles of graph g (module -> the modules it imports), each as "a -> b -> a";
    edges in allowed (default: ALLOWED) are left out. test_port_layers uses it too."""
    allowed = ALLOWED if allowed is None else allowed
    state = {}
    found = []

    def visit(m, stack):
        state[m] = 1
        stack.append(m)
        for d in sorted(g.get(m, ())):
            if d not in g or (m, d) in allowed:
                continue
            if state.get(d) == 1:
                found.append(" -> ".join(stack[stack.index(d):] + [d]))
            elif d not in state:
                visit(d, stack)
        stack.pop()
        state[m] = 2

    for m in sorted(g):
        if m not in state:
            visit(m, [])
    return found


def test_the_checker_sees_an_upward_import(tmp_path):
    # the rule itself: a driver importing the link layer is caught, lazily too
    p = tmp_path / "x.py"
    p.write_text("def f():\n    from ..link.discovery import encode_advert\n")
    known = {"acomm.drivers.x": str(p), "acomm.link.discovery": ""}
    deps = imports("acomm.drivers.x", str(p), known)
    assert deps == {"acomm.link.discovery"}
    assert layer_of("acomm.link.discovery") > layer_of("acomm.drivers.x")


def test_no_package_init_loads_its_whole_package():
    # a board that needs a CRC must not load the schema codec: an __init__
    # imports at most what its own main class needs, never all its siblings
    g = graph()
    for m, path in modules().items():
        if path.endswith("__init__.py"):
            siblings = [x for x in g if x.startswith(m + ".") and x.count(".") == m.count(".") + 1]
            got = [d for d in g[m] if d in siblings]
            assert len(siblings) < 2 or len(got) < len(siblings), (m, got)
