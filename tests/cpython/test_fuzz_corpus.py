# acomm fuzz --corpus: inputs that reach new lines of acomm are kept and
# mutated further, and runs add up in the folder (counts and coverage).
import json

from acomm_cpython.cli import main
from acomm_cpython.bench.fuzzcov import function_lines


def _lines(capsys):
    return [json.loads(x) for x in capsys.readouterr().out.splitlines()]


def test_runs_add_up_and_keep_what_found_new_code(tmp_path, capsys):
    d = str(tmp_path / "corpus")
    args = ["fuzz", "--cases", "40", "--corpus", d, "--trace-every", "2", "--target", "frame", "--target", "control"]
    assert main(args) == 0
    first = _lines(capsys)
    cum = [x for x in first if x["target"] == "cumulative"][0]
    cov = [x for x in first if x["target"] == "coverage"][0]
    assert [x["seed"] for x in first if x["target"] == "total"] == [1]
    assert cum["runs"] == 1 and cum["inputs"] == 80 and cum["failures"] == 0 and cum["kept_this_run"] > 0
    assert 0 < cov["reached"] < cov["acomm_function_lines"]
    kept = list((tmp_path / "corpus" / "control").iterdir())
    assert kept and all(p.read_bytes() for p in kept)
    assert main(args) == 0
    second = _lines(capsys)
    cum2 = [x for x in second if x["target"] == "cumulative"][0]
    assert [x["seed"] for x in second if x["target"] == "total"] == [2]  # a run of its own inputs
    assert cum2["runs"] == 2 and cum2["inputs"] == 160
    assert [x for x in second if x["target"] == "coverage"][0]["reached"] >= cov["reached"]


def test_function_lines_leave_out_module_level_code():
    fl = function_lines()
    assert 3000 < sum(len(v) for v in fl.values())
    frame = fl["frame/__init__.py"]
    src = open(__import__("acomm.frame").frame.__file__).read().splitlines()
    top = [i + 1 for i, line in enumerate(src) if line.startswith(("VERSION", "DATA =", "class Frame"))]
    assert top and not set(top) & frame
