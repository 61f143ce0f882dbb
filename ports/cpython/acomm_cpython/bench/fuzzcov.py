# `acomm fuzz --corpus DIR`: coverage-guided corpus and cumulative counts
# (CPython only: sys.settrace).
#
# One case in `every` runs under a line tracer limited to acomm/'s files.
# An input that reaches a line of acomm no traced input reached before is
# kept: written to DIR/<target>/<case>.bin and added to the target's corpus,
# so later cases mutate it (the search goes deeper from what found new
# code). The lines reached, the kept inputs and the counts of every run
# accumulate in DIR (lines.txt, totals.json), so runs add up.
#
# The coverage figure is over the lines of code inside acomm's functions
# (module level runs at import, before any input): the line numbers of
# every function's code object (dis.findlinestarts) in acomm/**.py, less
# each function's own first line.
import dis
import json
import os
import sys

import acomm

ROOT = os.path.dirname(os.path.abspath(acomm.__file__))
MAX_KEPT = 512  # inputs kept per target and run


def function_lines(root=ROOT):
    # -> {relative path: set of line numbers} of code inside functions
    out = {}
    for d, _, files in os.walk(root):
        for f in files:
            if not f.endswith(".py"):
                continue
            path = os.path.join(d, f)
            with open(path, "rb") as fh:
                src = fh.read()
            try:
                top = compile(src, path, "exec")
            except SyntaxError:
                continue
            lines = set()
            todo = [c for c in top.co_consts if hasattr(c, "co_code")]
            while todo:
                co = todo.pop()
                for _, ln in dis.findlinestarts(co):
                    if ln is not None and ln != co.co_firstlineno:
                        lines.add(ln)
                todo.extend(c for c in co.co_consts if hasattr(c, "co_code"))
            out[os.path.relpath(path, root)] = lines
    return out


class Tracer:
    """The hook of acomm_sim.fuzz.run: traces one case in `every`."""

    def __init__(self, dirpath, every=8):
        self.dir = dirpath
        self.every = every
        self.lines = set()  # (relative path, line)
        self.kept = {}  # target name -> inputs kept this run
        self._n = 0
        self._on = False
        self._new = False
        self._rel = {}  # code filename -> relative path or None
        os.makedirs(dirpath, exist_ok=True)
        p = os.path.join(dirpath, "lines.txt")
        if os.path.exists(p):
            with open(p) as f:
                for line in f:
                    path, _, ln = line.strip().rpartition(":")
                    if path:
                        self.lines.add((path, int(ln)))

    def load_corpus(self, targets):
        # inputs kept by earlier runs join each target's corpus
        n = 0
        for t in targets:
            d = os.path.join(self.dir, t.name)
            if not os.path.isdir(d):
                continue
            t.corpus = list(t.corpus)
            for f in sorted(os.listdir(d)):
                with open(os.path.join(d, f), "rb") as fh:
                    t.corpus.append(fh.read())
                    n += 1
        return n

    def _rel_of(self, filename):
        r = self._rel.get(filename, 0)
        if r == 0:
            a = os.path.abspath(filename)
            r = os.path.relpath(a, ROOT) if a.startswith(ROOT + os.sep) else None
            self._rel[filename] = r
        return r

    def _global(self, frame, event, arg):
        if self._rel_of(frame.f_code.co_filename) is None:
            return None
        return self._local

    def _local(self, frame, event, arg):
        if event == "line":
            k = (self._rel[frame.f_code.co_filename], frame.f_lineno)
            if k not in self.lines:
                self.lines.add(k)
                self._new = True
        return self._local

    def before(self):
        self._n += 1
        self._on = self._n % self.every == 0
        if self._on:
            self._new = False
            sys.settrace(self._global)

    def after(self, target, data):
        if not self._on:
            return
        sys.settrace(None)
        self._on = False
        if not self._new or not data:
            return
        k = self.kept.get(target.name, 0)
        if k >= MAX_KEPT:
            return
        self.kept[target.name] = k + 1
        d = os.path.join(self.dir, target.name)
        os.makedirs(d, exist_ok=True)
        with open(os.path.join(d, "%08d-%d.bin" % (self._n, k)), "wb") as f:
            f.write(data)
        target.corpus = list(target.corpus) + [bytes(data)]

    def runs(self):
        p = os.path.join(self.dir, "totals.json")
        if not os.path.exists(p):
            return 0
        with open(p) as f:
            return json.load(f)["runs"]

    def save(self, results, seconds):
        # -> the cumulative totals after this run
        with open(os.path.join(self.dir, "lines.txt"), "w") as f:
            for path, ln in sorted(self.lines):
                f.write("%s:%d\n" % (path, ln))
        p = os.path.join(self.dir, "totals.json")
        tot = {"runs": 0, "seconds": 0.0, "inputs": {}, "failures": {}}
        if os.path.exists(p):
            with open(p) as f:
                tot = json.load(f)
        tot["runs"] += 1
        tot["seconds"] = round(tot["seconds"] + seconds, 1)
        for r in results:
            tot["inputs"][r.name] = tot["inputs"].get(r.name, 0) + r.inputs
            tot["failures"][r.name] = tot["failures"].get(r.name, 0) + r.failures
        with open(p + ".new", "w") as f:
            json.dump(tot, f, indent=1, sort_keys=True)
        os.replace(p + ".new", p)
        return tot

    def coverage(self):
        # -> (lines reached, lines in acomm's functions)
        fl = function_lines()
        total = sum(len(v) for v in fl.values())
        hit = sum(1 for path, ln in self.lines if ln in fl.get(path, ()))
        return hit, total
