# The core's types, for users' editors and mypy (issue 34): acomm runs
# unchanged on MicroPython, so its .py files carry no annotations; the
# stubs beside them (acomm/**/*.pyi, with acomm/py.typed) do. Checked here:
#
#   - a typed user program (fixtures/typed_user.py) passes mypy --strict
#     against the stubs, and runs: the stubs describe what the code does;
#   - calls the stubs must refuse (fixtures/typed_wrong.py) fail, each on
#     its marked line with its error code, so this test can fail;
#   - every name a stub declares exists in its module with the same
#     parameters, and every public name of a stubbed module (and method of a
#     stubbed class) is in its stub: a stub cannot go stale silently;
#   - the wheel ships the stubs (setup.cfg's package_data);
#   - docs/quickstart.md's python blocks type-check (skipped until the page
#     is written against the typed API).
#
# mypy checks the fixtures (and, through them, every stub: each stub
# imports only stubbed modules, so mypy never reads an untyped .py of the
# core, where --strict would report its missing annotations). mypy finds
# the stubs through MYPYPATH (the checkout), as it would in an installed
# wheel; it does not follow setuptools' editable-install finder.

import ast
import configparser
import glob
import importlib
import importlib.util
import inspect
import os
import re
import subprocess
import sys
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
FIXTURES = os.path.join(HERE, "fixtures")
USER = os.path.join(FIXTURES, "typed_user.py")
WRONG = os.path.join(FIXTURES, "typed_wrong.py")

needs_mypy = pytest.mark.skipif(
    importlib.util.find_spec("mypy") is None,
    reason="mypy is not installed: pip install mypy (the dev extra has it: pip install -e '.[dev]', or make test)",
)


def python_blocks(path):
    """The ```python blocks of a markdown page, in order, joined into one program.

    Fences as tests/cpython/test_quickstart.py reads them: at the start of a
    line, the block's text up to the next line that starts with ```."""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    blocks = [m.group(2) for m in re.finditer(r"^```(\w*)[ \t]*\n(.*?)^```", text, re.S | re.M)
              if m.group(1) == "python"]
    return "\n\n".join(b.rstrip("\n") for b in blocks) + "\n"


def run_mypy(tmp_dir, files, path=(ROOT,), options=()):
    """mypy --strict on files, stubs from path (MYPYPATH), its cache and cwd in tmp_dir
    (no config file of the checkout applies; parallel runs do not share a cache)
    -> (exit status, output, seconds)."""
    env = dict(os.environ)
    env["MYPYPATH"] = os.pathsep.join(path)
    env.pop("MYPY_CACHE_DIR", None)
    cmd = [sys.executable, "-m", "mypy", "--strict", "--no-color-output", "--show-error-codes",
           "--cache-dir", os.path.join(str(tmp_dir), ".mypy_cache")] + list(options) + list(files)
    t = time.monotonic()
    r = subprocess.run(cmd, cwd=str(tmp_dir), env=env, capture_output=True, text=True, timeout=300)
    return r.returncode, r.stdout + r.stderr, time.monotonic() - t


_DIAG = re.compile(r"^(?P<path>[^:\n]+):(?P<line>\d+):(?:\d+:)? (?P<kind>error|note): "
                   r"(?P<msg>.*?)(?:  \[(?P<code>[\w-]+)\])?$", re.M)


def _errors(out):
    # [(file name, line, error code)] of mypy's errors
    return [(os.path.basename(m.group("path")), int(m.group("line")), m.group("code"))
            for m in _DIAG.finditer(out) if m.group("kind") == "error"]


@pytest.fixture(scope="module")
def checked(tmp_path_factory):
    # two runs on one cache: the second reads what the first parsed (the
    # stubs, typeshed) and takes a fraction of it
    tmp = tmp_path_factory.mktemp("mypy")
    user = run_mypy(tmp, [USER])
    wrong = run_mypy(tmp, [WRONG])
    print("mypy --strict: %.1f s on typed_user.py (cold cache), %.1f s on typed_wrong.py" % (user[2], wrong[2]))
    return {"user": user[:2], "wrong": wrong[:2]}


@needs_mypy
def test_a_typed_user_program_passes_strict(checked):
    rc, out = checked["user"]
    assert rc == 0 and not _errors(out), out


@needs_mypy
def test_calls_the_stubs_refuse_fail(checked):
    rc, out = checked["wrong"]
    want = set()
    with open(WRONG) as f:
        for n, line in enumerate(f, 1):
            m = re.search(r"#\s*E:\s*([\w-]+)\s*$", line)
            if m:
                want.add((n, m.group(1)))
    assert len(want) >= 10
    # exit 1: errors found (2 would be mypy's own trouble); each marked
    # line has its error, no other line of any file has one
    got = {(name, line, code) for name, line, code in _errors(out)}
    assert rc == 1 and got == {(os.path.basename(WRONG), n, code) for n, code in want}, (
        "expected (line, code) %s, mypy said:\n%s" % (sorted(want), out))


def test_the_typed_user_program_runs():
    spec = importlib.util.spec_from_file_location("typed_user", USER)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    got = mod.main()
    assert got["final"][1] == "delivered" and got["inbox"][0][1] == "diver_status"


def test_python_blocks_joins_a_pages_python_in_order(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("# T\n\n```python\na = 1\n```\n\ntext\n\n```sh\nls\n```\n\n```python\nb = a + 1\n\n\n```\n"
                    "```text\nout\n```\n")
    assert python_blocks(str(page)) == "a = 1\n\nb = a + 1\n"
    # the page test_quickstart_typechecks reads: python blocks that form one program
    quick = python_blocks(os.path.join(ROOT, "docs", "quickstart.md"))
    assert quick.strip()
    compile(quick, "quickstart.md", "exec")


@needs_mypy
@pytest.mark.parametrize("page", ["quickstart.md", "quickstart-blocking.md"])
def test_quickstart_typechecks(tmp_path, page):
    prog = tmp_path / page.replace("-", "_").replace(".md", ".py")
    prog.write_text(python_blocks(os.path.join(ROOT, "docs", page)))
    # In full: the page, and through it the library (acomm_cpython.aio,
    # blocking, eventview, ioloop, hosttransport: annotated inline) and the
    # stubs of everything they import (the core's, the port's I/O layer's).
    rc, out, _ = run_mypy(tmp_path, [str(prog)], (ROOT, os.path.join(ROOT, "ports", "cpython")))
    assert rc == 0, out
    assert "Success" in out


# --- the stubs against the modules ---------------------------------------------

STUBS = sorted(os.path.relpath(p, ROOT) for p in glob.glob(os.path.join(ROOT, "acomm", "**", "*.pyi"), recursive=True))
# the topside library's stubs (its I/O layer; aio, blocking and the rest carry annotations inline)
PORT = os.path.join("ports", "cpython") + os.sep
STUBS += sorted(os.path.relpath(p, ROOT) for p in glob.glob(os.path.join(ROOT, PORT, "acomm_cpython", "*.pyi")))
# dunder methods a stub must declare when the class defines them (they type
# len(), `in`, iteration, indexing, with, ==)
_DUNDERS = {"__init__", "__len__", "__iter__", "__contains__", "__getitem__", "__enter__", "__exit__", "__call__",
            "__eq__"}


def _module_of(rel):
    if rel.startswith(PORT):
        rel = rel[len(PORT):]
    parts = rel[: -len(".pyi")].split(os.sep)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _public(name):
    return not name.startswith("_") or (name.startswith("__") and name.endswith("__"))


def _toplevel(body):
    # defs, classes and assigned names of a module body, into if/try blocks
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            yield node.name, node
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            yield node.target.id, node
        elif isinstance(node, ast.Assign):
            for t in node.targets:
                for n in ast.walk(t):
                    if isinstance(n, ast.Name):
                        yield n.id, node
        elif isinstance(node, ast.ImportFrom):
            # `from x import y as y`: an explicit re-export in a stub
            for a in node.names:
                if a.asname is not None and a.asname == a.name:
                    yield a.name, node
        elif isinstance(node, ast.If):
            yield from _toplevel(node.body)
            yield from _toplevel(node.orelse)
        elif isinstance(node, ast.Try):
            yield from _toplevel(node.body)
            for h in node.handlers:
                yield from _toplevel(h.body)
            yield from _toplevel(node.orelse)
            yield from _toplevel(node.finalbody)


def _parse(path):
    with open(path, encoding="utf-8") as f:
        return ast.parse(f.read(), path)


def _stub_params(fn):
    # [(name, kind, has a default)]: kind pos, *, kw, **
    a = fn.args
    pos = a.posonlyargs + a.args
    first_default = len(pos) - len(a.defaults)
    out = [(p.arg, "pos", i >= first_default) for i, p in enumerate(pos)]
    if a.vararg:
        out.append(("*", "*", False))
    out += [(p.arg, "kw", d is not None) for p, d in zip(a.kwonlyargs, a.kw_defaults)]
    if a.kwarg:
        out.append(("**", "**", False))
    return out


def _real_params(fn):
    out = []
    for p in inspect.signature(fn).parameters.values():
        if p.kind == p.VAR_POSITIONAL:
            out.append(("*", "*", False))
        elif p.kind == p.VAR_KEYWORD:
            out.append(("**", "**", False))
        else:
            out.append((p.name, "kw" if p.kind == p.KEYWORD_ONLY else "pos", p.default is not p.empty))
    return out


def _same_signature(stub_fn, real_fn):
    s, r = _stub_params(stub_fn), _real_params(real_fn)
    if s == r:
        return True
    # **options in the code may be spelled out in the stub as keyword-only parameters
    if ("**", "**", False) in r and ("**", "**", False) not in s:
        return [p for p in s if p[1] != "kw"] == [p for p in r if p[1] != "**"]
    return False


def _unwrap(attr):
    if isinstance(attr, (staticmethod, classmethod)):
        return attr.__func__
    if isinstance(attr, property):
        return attr.fget
    return attr


def _class_attr(cls, name):
    # the attribute as defined (no binding), from the first class of the MRO that has it
    for k in cls.__mro__:
        if name in vars(k):
            return _unwrap(vars(k)[name])
    return None


def _self_attrs(tree):
    # names assigned as self.NAME anywhere in the module (instance attributes)
    out = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.Assign):
            targets = n.targets
        elif isinstance(n, (ast.AnnAssign, ast.AugAssign)):
            targets = [n.target]
        else:
            continue
        for t in targets:
            for x in ast.walk(t):
                if isinstance(x, ast.Attribute) and isinstance(x.value, ast.Name) and x.value.id == "self":
                    out.add(x.attr)
    return out


def _stub_class_members(cls):
    # names the stubs declare for a class and its bases (each in its module's stub)
    names = set()
    for k in cls.__mro__:
        top = os.path.join(ROOT, PORT) if k.__module__.startswith("acomm_cpython.") else ROOT
        path = os.path.join(top, *k.__module__.split("."))
        path = os.path.join(path, "__init__.pyi") if os.path.isdir(path) else path + ".pyi"
        if not os.path.isfile(path):
            continue
        for c in _parse(path).body:
            if isinstance(c, ast.ClassDef) and c.name == k.__name__:
                for n in c.body:
                    if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)):
                        names.add(n.name)
                    elif isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name):
                        names.add(n.target.id)
    return names


def _check_class(where, cls_node, real_cls, real_tree, problems):
    self_attrs = _self_attrs(real_tree)
    for n in cls_node.body:
        if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)):
            real = _class_attr(real_cls, n.name)
            if real is None:
                problems.append("%s.%s: no such method" % (where, n.name))
            elif inspect.isfunction(real) and not _same_signature(n, real):
                problems.append("%s.%s: stub %s, code %s" % (where, n.name, _stub_params(n), _real_params(real)))
        elif isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name):
            name = n.target.id
            if not hasattr(real_cls, name) and name not in self_attrs:
                problems.append("%s.%s: no such attribute" % (where, name))
    # the other way: every method the class defines is in the stub
    real_node = next((c for c in ast.walk(real_tree) if isinstance(c, ast.ClassDef) and c.name == cls_node.name), None)
    declared = _stub_class_members(real_cls)
    if real_node is not None:
        for n in real_node.body:
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and (
                    not n.name.startswith("_") or n.name in _DUNDERS) and n.name not in declared:
                problems.append("%s.%s: in the code, not in the stub" % (where, n.name))


def test_every_stubbed_module_has_a_stub_beside_it():
    assert len(STUBS) >= 15 and os.path.isfile(os.path.join(ROOT, "acomm", "py.typed"))
    for rel in STUBS:
        assert os.path.isfile(os.path.join(ROOT, rel[:-1])), "%s has no module beside it" % rel


@pytest.mark.parametrize("rel", STUBS)
def test_stub_matches_its_module(rel):
    modname = _module_of(rel)
    mod = importlib.import_module(modname)
    stub = _parse(os.path.join(ROOT, rel))
    real_tree = _parse(mod.__file__)
    declared = {}
    for name, node in _toplevel(stub.body):
        if _public(name):
            declared[name] = node
    problems = []
    for name, node in declared.items():
        where = "%s.%s" % (modname, name)
        if not hasattr(mod, name):
            problems.append("%s: not in the module" % where)
            continue
        real = getattr(mod, name)
        if isinstance(node, ast.ClassDef):
            if not inspect.isclass(real):
                problems.append("%s: a class in the stub, %r in the code" % (where, type(real).__name__))
            else:
                _check_class(where, node, real, real_tree, problems)
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            if not callable(real):
                problems.append("%s: a function in the stub, %r in the code" % (where, type(real).__name__))
            elif inspect.isfunction(real) and not _same_signature(node, real):
                problems.append("%s: stub %s, code %s" % (where, _stub_params(node), _real_params(real)))
    # the other way: every public name the module defines is in its stub
    for name, _ in _toplevel(real_tree.body):
        if _public(name) and name not in declared:
            problems.append("%s.%s: in the module, not in the stub" % (modname, name))
    assert not problems, "\n".join(sorted(set(problems)))


def test_the_wheel_ships_the_stubs():
    # setup.cfg's package_data: "*.pyi" for every package that has stubs,
    # and py.typed (PEP 561) for acomm
    cfg = configparser.ConfigParser()
    cfg.read(os.path.join(ROOT, "setup.cfg"))
    data = {k: [g.strip() for g in re.split(r"[,\n]", v) if g.strip()] for k, v in cfg["options.package_data"].items()}
    for_all = data.get("*", []) + data.get("", [])
    packages = set()
    for rel in STUBS:
        packages.add(_module_of(os.path.join(os.path.dirname(rel), "__init__.pyi")))
    for pkg in sorted(packages):
        assert "*.pyi" in data.get(pkg, []) + for_all, "setup.cfg [options.package_data] %s: add *.pyi" % pkg
    assert "py.typed" in data.get("acomm", []) + for_all
    assert "py.typed" in data.get("acomm_cpython", []) + for_all
    listed = [p.strip() for p in cfg["options"]["packages"].split()]
    assert packages <= set(listed), packages - set(listed)
