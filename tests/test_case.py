"""Case files: the paper's case parses and round-trips; every bad input names its key."""

from __future__ import annotations

import copy
import json
import math

import pytest

from warpcontact.records.case import (
    DEFAULT_K_VM,
    AdhesionSpec,
    Case,
    FrictionSpec,
    LoadSpec,
    SolverSpec,
    case_from_dict,
    load_case,
)
from warpcontact.errors import InputError
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import MaterialPair

#: The paper's case: copper asperity (R = 10 um) on hardened steel, delta_z = 5.0e-5 um.
PAPER_TOML = """\
# Copper asperity on a hardened steel flat (the paper's Table 1), SI units.
[sphere]
radius = 10e-6
E = 106e9
nu = 0.33
yield_strength = 200e6
hardness = 1.0e9

[flat]
E = 205e9
nu = 0.31
yield_strength = 345e6
hardness = 6.2e9

[grid]
n = 64
size = 1e-7

[load]
delta_z = 5e-11
"""


def paper_dict() -> dict:
    return {
        "sphere": {"radius": 10e-6, "E": 106e9, "nu": 0.33, "yield_strength": 200e6, "hardness": 1.0e9},
        "flat": {"E": 205e9, "nu": 0.31, "yield_strength": 345e6, "hardness": 6.2e9},
        "grid": {"n": 64, "size": 1e-7},
        "load": {"delta_z": 5e-11},
    }


# --- a tiny TOML writer, so that bad values (nan, inf, wrong types) go through the real parser ---


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else ("-inf" if v == -math.inf else repr(v)))
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(v)


def to_toml(d: dict) -> str:
    lines = []
    for key, value in d.items():
        if isinstance(value, dict):
            lines.append(f"[{key}]")
            lines += [f"{k} = {_toml_value(v)}" for k, v in value.items()]
            lines.append("")
        else:
            lines.insert(0, f"{key} = {_toml_value(value)}")
    return "\n".join(lines) + "\n"


# --- the paper's case ---


def test_paper_case_parses(tmp_path):
    f = tmp_path / "paper.toml"
    f.write_text(PAPER_TOML, encoding="utf-8")
    case = load_case(f)
    assert isinstance(case.pair, MaterialPair)
    assert isinstance(case.sphere, Sphere) and isinstance(case.grid, Grid)
    assert case.sphere.radius == 10e-6 and case.sphere.profile == "sphere"
    assert case.pair.sphere.E == 106e9 and case.pair.flat.hardness == 6.2e9
    assert case.pair.E_star == pytest.approx(78.03e9, rel=1e-4)  # MODEL.md section 1
    assert case.pair.dundurs_beta == pytest.approx(0.0717, abs=1e-4)
    assert case.grid.n == 64 and case.grid.dx == pytest.approx(1e-7 / 64)
    assert case.load.path() == [(0.0, 0.0, 5e-11)]
    assert case.solver == SolverSpec(device="cpu", dtype="float64", tol=1e-10, max_iter=2000, max_turns=1000, fft="auto")
    assert case.friction is None and case.adhesion is None
    assert case == case_from_dict(paper_dict())


def test_paper_case_round_trips(tmp_path):
    f = tmp_path / "paper.toml"
    f.write_text(PAPER_TOML, encoding="utf-8")
    case = load_case(f)
    d = case.to_dict()
    text = json.dumps(d, allow_nan=False)  # JSON-serialisable, no NaN/inf literals
    assert case_from_dict(json.loads(text)) == case
    assert case_from_dict(d) == case
    # The written dict is also a valid case file.
    g = tmp_path / "again.toml"
    g.write_text(to_toml(d), encoding="utf-8")
    assert load_case(g) == case


def test_full_case_round_trips():
    d = paper_dict()
    d["sphere"]["profile"] = "paraboloid"
    del d["flat"]["yield_strength"]  # -> inf, written as "inf"
    d["load"] = {"path": [[0, 0, 2e-11], [0.0, 0.0, 5e-11], [1e-11, -1e-11, 5e-11]]}
    d["solver"] = {"device": "cuda:1", "dtype": "float32", "max_iter": 500, "fft": "cupy", "response_float32": True}
    d["friction"] = {"law": "tabor", "k_tau": 0.8, "hardness_cap": True}
    d["adhesion"] = {"law": "smc", "sigma_max": 1e8, "tau_max": 5e7, "delta_n": 1e-9, "delta_t": 2e-9}
    case = case_from_dict(d)
    out = case.to_dict()
    assert out["flat"]["yield_strength"] == "inf"
    assert case.pair.flat.yield_strength == math.inf
    assert case.solver.tol == 1e-5  # float32 default
    assert case.load.path() == [(0.0, 0.0, 2e-11), (0.0, 0.0, 5e-11), (1e-11, -1e-11, 5e-11)]
    assert case.friction.k_vm == DEFAULT_K_VM
    assert case.friction.mu_b == pytest.approx(0.7698, abs=1e-4)  # MODEL.md section 5
    assert case.adhesion.work_of_adhesion == pytest.approx(math.e * 1e8 * 1e-9)
    assert case_from_dict(json.loads(json.dumps(out, allow_nan=False))) == case


def test_coulomb_and_dugdale_round_trip():
    d = paper_dict()
    d["friction"] = {"law": "coulomb", "mu": 0}  # int accepted where a float is expected
    d["adhesion"] = {"law": "dugdale", "sigma_0": 2e8, "h_0": 5e-10}
    case = case_from_dict(d)
    assert case.friction == FrictionSpec("coulomb", mu=0.0)
    assert case.adhesion == AdhesionSpec("dugdale", sigma_0=2e8, h_0=5e-10)
    assert case_from_dict(case.to_dict()) == case


def test_accepted_edges(tmp_path):
    d = paper_dict()
    d["sphere"]["nu"] = 0.5  # incompressible: accepted
    d["flat"]["hardness"] = math.inf  # TOML inf: no limit
    d["sphere"]["yield_strength"] = "inf"
    d["grid"]["n"] = 8
    d["solver"] = {"tol": 1e-2, "device": "cuda", "fft": "warp"}
    f = tmp_path / "edges.toml"
    f.write_text(to_toml(d), encoding="utf-8")
    case = load_case(f)
    assert case.pair.sphere.nu == 0.5
    assert case.pair.flat.hardness == math.inf and case.pair.sphere.yield_strength == math.inf
    assert case.solver.tol == 1e-2 and case.solver.device == "cuda"


def test_byte_order_mark_is_tolerated(tmp_path):
    f = tmp_path / "bom.toml"
    f.write_bytes(b"\xef\xbb\xbf" + PAPER_TOML.encode())
    assert load_case(f) == case_from_dict(paper_dict())


def test_default_path():
    assert LoadSpec(delta_z=3e-11, steps=3).path() == [(0.0, 0.0, 1e-11), (0.0, 0.0, 2e-11), (0.0, 0.0, 3e-11)]
    path = LoadSpec(delta_z=4e-11, delta_x=2e-11, delta_y=-2e-11, steps=2).path()
    assert path == [(0.0, 0.0, 2e-11), (0.0, 0.0, 4e-11), (1e-11, -1e-11, 4e-11), (2e-11, -2e-11, 4e-11)]
    assert LoadSpec(delta_z=4e-11, delta_x=2e-11, steps=2).delta_z_max == 4e-11
    explicit = LoadSpec(states=((0, 0, 1e-11), (0, 0, 3e-11), (0, 0, -1e-11)))
    assert explicit.explicit and explicit.delta_z_max == 3e-11
    assert explicit.path()[2] == (0.0, 0.0, -1e-11)


def test_with_overrides():
    case = case_from_dict(paper_dict())
    f32 = case.with_overrides(dtype="float32")
    assert f32.solver.dtype == "float32" and f32.solver.tol == 1e-5  # defaulted tol follows the dtype
    assert f32.with_overrides(dtype="float64").solver.tol == 1e-10
    assert case.solver.dtype == "float64"  # the original is unchanged
    gpu = case.with_overrides(device="cuda:0", fft="cupy")
    assert (gpu.solver.device, gpu.solver.fft) == ("cuda:0", "cupy")
    assert gpu.pair == case.pair and gpu.load == case.load
    assert case.with_overrides() == case
    d = paper_dict()
    d["solver"] = {"tol": 1e-7}
    assert case_from_dict(d).with_overrides(dtype="float32").solver.tol == 1e-7  # an explicit tol stays
    with pytest.raises(InputError) as e:
        case.with_overrides(device="tpu")
    assert e.value.key == "solver.device"
    with pytest.raises(InputError) as e:
        gpu.with_overrides(device="cpu")  # cupy cannot run on the CPU
    assert e.value.key == "solver.fft"


# --- bad inputs, table-driven ---


def _set(path: str, value):
    def mutate(d):
        *tables, key = path.split(".")
        t = d
        for name in tables:
            t = t.setdefault(name, {})
        t[key] = copy.deepcopy(value)  # tables shared between cases stay untouched

    return mutate


def _del(path: str):
    def mutate(d):
        *tables, key = path.split(".")
        t = d
        for name in tables:
            t = t[name]
        del t[key]

    return mutate


def _all(*mutations):
    def mutate(d):
        for m in mutations:
            m(d)

    return mutate


TABOR = _set("friction", {"law": "tabor", "k_tau": 0.8})
SMC = {"law": "smc", "sigma_max": 1e8, "tau_max": 5e7, "delta_n": 1e-9, "delta_t": 2e-9}

#: (id, mutation of the paper's dict, expected key). The case is written as TOML and loaded.
BAD_CASES = [
    # missing tables and keys
    ("missing-sphere-table", _del("sphere"), "sphere"),
    ("missing-sphere-radius", _del("sphere.radius"), "sphere.radius"),
    ("missing-sphere-E", _del("sphere.E"), "sphere.E"),
    ("missing-flat-nu", _del("flat.nu"), "flat.nu"),
    ("missing-grid-n", _del("grid.n"), "grid.n"),
    ("missing-grid-size", _del("grid.size"), "grid.size"),
    ("missing-load-delta_z", _del("load.delta_z"), "load.delta_z"),
    # unknown keys and tables, wrong table types
    ("unknown-key-typo", _set("sphere.radious", 1e-5), "sphere.radious"),
    ("unknown-key-case", _set("flat.e", 1e9), "flat.e"),
    ("unknown-solver-key", _set("solver.tolerance", 1e-8), "solver.tolerance"),
    ("unknown-table", _set("mesh", {"n": 64}), "mesh"),
    ("unknown-top-level-key", _set("title", "x"), "title"),
    ("grid-not-a-table", _set("grid", 5), "grid"),
    # wrong types
    ("E-string", _set("sphere.E", "106e9"), "sphere.E"),
    ("E-bool", _set("sphere.E", True), "sphere.E"),
    ("radius-array", _set("sphere.radius", [1e-5]), "sphere.radius"),
    ("nu-bool", _set("flat.nu", False), "flat.nu"),
    ("yield-strength-string", _set("sphere.yield_strength", "big"), "sphere.yield_strength"),
    ("profile-unknown", _set("sphere.profile", "cylinder"), "sphere.profile"),
    ("profile-not-string", _set("sphere.profile", 1), "sphere.profile"),
    # NaN and inf through TOML's nan / inf
    ("E-nan", _set("sphere.E", math.nan), "sphere.E"),
    ("E-inf", _set("sphere.E", math.inf), "sphere.E"),
    ("radius-inf", _set("sphere.radius", math.inf), "sphere.radius"),
    ("nu-nan", _set("sphere.nu", math.nan), "sphere.nu"),
    ("hardness-nan", _set("flat.hardness", math.nan), "flat.hardness"),
    ("hardness-minus-inf", _set("flat.hardness", -math.inf), "flat.hardness"),
    ("size-nan", _set("grid.size", math.nan), "grid.size"),
    # signs and ranges of the bodies
    ("E-negative", _set("flat.E", -205e9), "flat.E"),
    ("E-zero", _set("sphere.E", 0.0), "sphere.E"),
    ("radius-negative", _set("sphere.radius", -1e-5), "sphere.radius"),
    ("radius-zero", _set("sphere.radius", 0), "sphere.radius"),
    ("nu-0.6", _set("sphere.nu", 0.6), "sphere.nu"),
    ("nu-minus-1", _set("flat.nu", -1.0), "flat.nu"),
    ("yield-strength-negative", _set("sphere.yield_strength", -2e8), "sphere.yield_strength"),
    ("hardness-zero", _set("flat.hardness", 0.0), "flat.hardness"),
    # the grid
    ("n-7", _set("grid.n", 7), "grid.n"),
    ("n-8.5", _set("grid.n", 8.5), "grid.n"),
    ("n-float-64.0", _set("grid.n", 64.0), "grid.n"),
    ("n-string", _set("grid.n", "64"), "grid.n"),
    ("size-zero", _set("grid.size", 0.0), "grid.size"),
    ("domain-smaller-than-contact", _set("grid.size", 4e-8), "grid.size"),
    ("domain-smaller-than-path-contact", _set("load", {"path": [[0, 0, 5e-11], [0, 0, 1e-9]]}), "grid.size"),
    ("domain-beyond-sphere", _set("grid.size", 1.5e-5), "grid.size"),
    # the load
    ("delta_z-nan", _set("load.delta_z", math.nan), "load.delta_z"),
    ("delta_z-string", _set("load.delta_z", "5e-11"), "load.delta_z"),
    ("delta_x-inf", _set("load.delta_x", math.inf), "load.delta_x"),
    ("steps-zero", _set("load.steps", 0), "load.steps"),
    ("steps-float", _set("load.steps", 2.0), "load.steps"),
    ("steps-too-many", _set("load.steps", 10**9), "load.steps"),
    ("path-nan", _set("load", {"path": [[0, 0, 1e-11], [0, 0, math.nan]]}), "load.path"),
    ("path-inf", _set("load", {"path": [[math.inf, 0, 1e-11]]}), "load.path"),
    ("path-short-entry", _set("load", {"path": [[0, 0, 1e-11], [0, 5e-11]]}), "load.path"),
    ("path-flat-array", _set("load", {"path": [0, 0, 5e-11]}), "load.path"),
    ("path-not-array", _set("load", {"path": 5e-11}), "load.path"),
    ("path-empty", _set("load", {"path": []}), "load.path"),
    ("path-string-entry", _set("load", {"path": [[0, 0, "5e-11"]]}), "load.path"),
    ("path-with-delta_z", _set("load.path", [[0, 0, 5e-11]]), "load.delta_z"),
    ("path-with-steps", _set("load", {"path": [[0, 0, 5e-11]], "steps": 2}), "load.steps"),
    ("path-with-amplitude", _set("load", {"path": [[0, 0, 5e-11]], "delta_x_amplitude": 1e-11}),
     "load.delta_x_amplitude"),
    ("normal_steps-zero", _set("load.normal_steps", 0), "load.normal_steps"),
    ("amplitude-zero", _set("load.delta_x_amplitude", 0.0), "load.delta_x_amplitude"),
    ("amplitude-negative", _set("load.delta_y_amplitude", -1e-11), "load.delta_y_amplitude"),
    ("amplitude-string", _set("load.delta_x_amplitude", "10 pm"), "load.delta_x_amplitude"),
    ("amplitude-off-the-grid", _set("load.delta_x_amplitude", 1e-6), "load.delta_x_amplitude"),
    ("amplitude-with-delta_x", _set("load", {"delta_z": 5e-11, "delta_x": 1e-11, "delta_x_amplitude": 1e-11}),
     "load.delta_x"),
    ("cycles-without-amplitude", _set("load.cycles", 2), "load.cycles"),
    ("cycles-zero", _set("load", {"delta_z": 5e-11, "delta_x_amplitude": 1e-11, "cycles": 0}), "load.cycles"),
    ("cycles-float", _set("load", {"delta_z": 5e-11, "delta_x_amplitude": 1e-11, "cycles": 2.0}), "load.cycles"),
    ("cycles-too-many-states", _set("load", {"delta_z": 5e-11, "delta_x_amplitude": 1e-11, "cycles": 10000,
                                             "tangential_steps": 100}), "load.cycles"),
    # the solver
    ("device-tpu", _set("solver.device", "tpu"), "solver.device"),
    ("device-cuda-colon", _set("solver.device", "cuda:"), "solver.device"),
    ("device-number", _set("solver.device", 0), "solver.device"),
    ("dtype-float16", _set("solver.dtype", "float16"), "solver.dtype"),
    ("fft-unknown", _set("solver.fft", "mkl"), "solver.fft"),
    ("fft-cupy-on-cpu", _set("solver.fft", "cupy"), "solver.fft"),
    ("fft-scipy-on-cuda", _set("solver", {"device": "cuda", "fft": "scipy"}), "solver.fft"),
    ("fft-fftw-on-cuda", _set("solver", {"device": "cuda", "fft": "fftw"}), "solver.fft"),
    ("tol-zero", _set("solver.tol", 0.0), "solver.tol"),
    ("tol-too-large", _set("solver.tol", 0.1), "solver.tol"),
    ("tol-nan", _set("solver.tol", math.nan), "solver.tol"),
    ("max_iter-zero", _set("solver.max_iter", 0), "solver.max_iter"),
    ("max_turns-zero", _set("solver.max_turns", 0), "solver.max_turns"),
    ("max_turns-float", _set("solver.max_turns", 10.0), "solver.max_turns"),
    ("response_float32-string", _set("solver.response_float32", "sometimes"), "solver.response_float32"),
    # friction
    ("friction-law-unknown", _set("friction", {"law": "amontons", "mu": 0.3}), "friction.law"),
    ("friction-law-missing", _set("friction", {"mu": 0.3}), "friction.law"),
    ("coulomb-mu-negative", _set("friction", {"law": "coulomb", "mu": -0.1}), "friction.mu"),
    ("coulomb-mu-missing", _set("friction", {"law": "coulomb"}), "friction.mu"),
    ("coulomb-mu-inf", _set("friction", {"law": "coulomb", "mu": math.inf}), "friction.mu"),
    ("coulomb-with-k_tau", _set("friction", {"law": "coulomb", "mu": 0.3, "k_tau": 0.5}), "friction.k_tau"),
    ("tabor-k_tau-0", _set("friction", {"law": "tabor", "k_tau": 0.0}), "friction.k_tau"),
    ("tabor-k_tau-1", _set("friction", {"law": "tabor", "k_tau": 1}), "friction.k_tau"),
    ("tabor-k_tau-missing", _set("friction", {"law": "tabor"}), "friction.k_tau"),
    ("tabor-with-mu", _set("friction", {"law": "tabor", "k_tau": 0.8, "mu": 0.3}), "friction.mu"),
    ("tabor-k_vm-zero", _all(TABOR, _set("friction.k_vm", 0.0)), "friction.k_vm"),
    ("tabor-hardness_cap-string", _all(TABOR, _set("friction.hardness_cap", "yes")), "friction.hardness_cap"),
    (
        "tabor-hardness_cap-without-hardness",
        _all(TABOR, _set("friction.hardness_cap", True), _del("sphere.hardness")),
        "friction.hardness_cap",
    ),
    # adhesion
    ("smc-missing-delta_n", _set("adhesion", {k: v for k, v in SMC.items() if k != "delta_n"}), "adhesion.delta_n"),
    ("smc-sigma_max-negative", _set("adhesion", {**SMC, "sigma_max": -1e8}), "adhesion.sigma_max"),
    ("smc-delta_t-zero", _set("adhesion", {**SMC, "delta_t": 0.0}), "adhesion.delta_t"),
    ("smc-with-h_0", _set("adhesion", {**SMC, "h_0": 1e-9}), "adhesion.h_0"),
    ("adhesion-law-unknown", _set("adhesion", {"law": "jkr"}), "adhesion.law"),
    ("dugdale-h_0-zero", _set("adhesion", {"law": "dugdale", "sigma_0": 1e8, "h_0": 0.0}), "adhesion.h_0"),
    ("dugdale-missing-sigma_0", _set("adhesion", {"law": "dugdale", "h_0": 1e-9}), "adhesion.sigma_0"),
]


@pytest.mark.parametrize("mutate, key", [pytest.param(m, k, id=i) for i, m, k in BAD_CASES])
def test_bad_case(tmp_path, mutate, key):
    d = copy.deepcopy(paper_dict())
    mutate(d)
    f = tmp_path / "bad.toml"
    f.write_text(to_toml(d), encoding="utf-8")
    with pytest.raises(InputError) as e:
        load_case(f)
    assert e.value.key == key, str(e.value)
    message = str(e.value)
    assert message.startswith(f"{key}: ") and "\n" not in message and len(e.value.problem) > 5
    # The same dict, not through TOML, gives the same error.
    with pytest.raises(InputError) as e2:
        case_from_dict(d)
    assert e2.value.key == key


def _non_utf8(tmp_path):
    f = tmp_path / "latin1.toml"
    f.write_bytes(PAPER_TOML.replace("# Copper", "# Kupfer \xfcber").encode("latin-1"))
    return f


def _truncated(tmp_path):
    f = tmp_path / "truncated.toml"
    text = PAPER_TOML.encode()
    f.write_bytes(text[: text.index(b"size = 1e-7") + len(b"size = ")])
    return f


def _truncated_table_header(tmp_path):
    f = tmp_path / "header.toml"
    f.write_text(PAPER_TOML + "\n[solver\n", encoding="utf-8")
    return f


def _duplicate_key(tmp_path):
    f = tmp_path / "duplicate.toml"
    f.write_text(PAPER_TOML.replace("n = 64", "n = 64\nn = 128"), encoding="utf-8")
    return f


def _missing(tmp_path):
    return tmp_path / "no-such-case.toml"


def _directory(tmp_path):
    d = tmp_path / "a-directory.toml"
    d.mkdir()
    return d


#: (id, function making the bad file) -> the key is the file's path.
BAD_FILES = [
    ("non-utf8", _non_utf8),
    ("truncated-value", _truncated),
    ("truncated-table-header", _truncated_table_header),
    ("duplicate-key", _duplicate_key),
    ("missing-file", _missing),
    ("directory", _directory),
]


@pytest.mark.parametrize("make", [pytest.param(m, id=i) for i, m in BAD_FILES])
def test_bad_file(tmp_path, make):
    path = make(tmp_path)
    with pytest.raises(InputError) as e:
        load_case(path)
    assert e.value.key == str(path)
    assert "\n" not in str(e.value) and str(e.value).startswith(f"{path}: ")


def test_messages_help():
    """Messages name the problem and, where it helps, the fix."""
    d = paper_dict()
    d["grid"]["size"] = 4e-8
    with pytest.raises(InputError, match=r"2 a = 4\.472e-08 m.*at least 5\.59e-08 m \(2\.5 a\)"):
        case_from_dict(d)
    d = paper_dict()
    d["sphere"]["radious"] = 1e-5
    with pytest.raises(InputError, match="did you mean 'radius'"):
        case_from_dict(d)
    d = paper_dict()
    del d["sphere"]["E"]
    with pytest.raises(InputError, match="^sphere.E: is required$"):
        case_from_dict(d)
    with pytest.raises(InputError, match="must be a number, got boolean true"):
        case_from_dict({**paper_dict(), "grid": {"n": 64, "size": True}})


def test_specs_validate_themselves():
    with pytest.raises(InputError) as e:
        SolverSpec(dtype="float16")
    assert e.value.key == "solver.dtype"
    with pytest.raises(InputError) as e:
        LoadSpec(delta_z=5e-11, states=((0, 0, 1e-11),))
    assert e.value.key == "load.delta_z"
    with pytest.raises(InputError) as e:
        FrictionSpec("tabor", k_tau=1.5)
    assert e.value.key == "friction.k_tau"
    with pytest.raises(InputError) as e:
        AdhesionSpec("smc", sigma_max=1.0, tau_max=1.0, delta_n=1.0)
    assert e.value.key == "adhesion.delta_t"
    case = case_from_dict(paper_dict())
    with pytest.raises(InputError) as e:
        Case(case.pair, case.sphere, Grid(64, 1e-8), case.load)
    assert e.value.key == "grid.size"


def test_documented_examples_parse():
    """The TOML examples in docs/case-files.md are valid cases (or [load] tables)."""
    import pathlib
    import re

    doc = (pathlib.Path(__file__).resolve().parents[1] / "docs" / "case-files.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```toml\n(.*?)```", doc, flags=re.S)
    assert len(blocks) == 2
    from warpcontact.records.case import tomllib

    paper = case_from_dict(tomllib.loads(blocks[0]))
    assert paper.friction.mu_b == pytest.approx(0.7698, abs=1e-4)
    assert len(paper.load.path()) == 20 and paper.load.path()[-1] == (4e-11, 0.0, 5e-11)
    d = paper_dict()
    d["load"] = tomllib.loads(blocks[1])["load"]
    assert case_from_dict(d).load.path()[-1] == (0.0, 0.0, -1e-11)


def test_a_key_in_the_wrong_case_names_the_key_meant():
    """``e = 210e9`` in [sphere]: "did you mean 'E'" (difflib alone finds no match for one letter)."""
    from pathlib import Path

    from warpcontact.records.case import tomllib

    base = tomllib.loads((Path(__file__).resolve().parents[1] / "examples" / "hertz.toml").read_text())
    base["sphere"]["e"] = base["sphere"].pop("E")
    with pytest.raises(InputError, match="sphere.e: unknown key; did you mean 'E'"):
        case_from_dict(base)


def test_with_overrides_takes_any_dotted_key_as_sweeps_do():
    from pathlib import Path

    from warpcontact.records.case import tomllib

    base = case_from_dict(tomllib.loads((Path(__file__).resolve().parents[1] / "examples" / "figure2c.toml").read_text()))
    case = base.with_overrides({"grid.n": 64, "friction.k_tau": 0.8}, device="cpu")
    assert case.grid.n == 64 and case.friction.k_tau == 0.8 and case.solver.device == "cpu"
    assert case.pair == base.pair and case.load == base.load  # nothing else moves
    assert base.with_overrides({"solver.dtype": "float32"}).solver.tol == 1e-5  # a defaulted tol follows the dtype
    explicit = base.with_overrides({"load.path": [[0.0, 0.0, 1e-10]]})
    assert explicit.load.explicit and explicit.load.path() == [(0.0, 0.0, 1e-10)]
    with pytest.raises(InputError, match="grid.nn: unknown key; did you mean 'n'"):
        base.with_overrides({"grid.nn": 3})
    with pytest.raises(InputError, match="friction.k_tau"):
        base.with_overrides({"friction.k_tau": 1.5})


def test_the_tangential_leg_takes_steps_of_its_own():
    d = {"sphere": {"radius": 1e-5, "E": 106e9, "nu": 0.33}, "flat": {"E": 205e9, "nu": 0.31},
         "grid": {"n": 32, "size": 1e-7}, "load": {"delta_z": 1e-10, "delta_x": 3e-11, "steps": 4,
                                                     "tangential_steps": 2}}
    case = case_from_dict(d)
    assert case.load.path() == [(0.0, 0.0, 2.5e-11), (0.0, 0.0, 5e-11), (0.0, 0.0, 7.5e-11), (0.0, 0.0, 1e-10),
                                (1.5e-11, 0.0, 1e-10), (3e-11, 0.0, 1e-10)]
    assert case_from_dict(case.to_dict()) == case
    d["load"]["tangential_steps"] = 0
    with pytest.raises(InputError, match="load.tangential_steps"):
        case_from_dict(d)
    del d["load"]["tangential_steps"]
    assert len(case_from_dict(d).load.path()) == 8  # steps for both legs, as before


def test_the_normal_leg_takes_steps_of_its_own():
    d = paper_dict()
    d["load"] = {"delta_z": 4e-11, "delta_x": 2e-11, "steps": 2, "normal_steps": 4}
    case = case_from_dict(d)
    assert case.load.path() == [(0.0, 0.0, 1e-11), (0.0, 0.0, 2e-11), (0.0, 0.0, 3e-11), (0.0, 0.0, 4e-11),
                                (1e-11, 0.0, 4e-11), (2e-11, 0.0, 4e-11)]
    assert case_from_dict(case.to_dict()) == case


def test_a_cyclic_path():
    """0 -> +A in tangential_steps steps (the first quarter), then each cycle +A -> -A -> +A in
    4 x tangential_steps, both amplitudes in phase, after normal_steps normal steps; every
    reversal lands exactly on +-A and every crossing on 0."""
    d = paper_dict()
    d["load"] = {"delta_z": 4e-11, "delta_x_amplitude": 2e-11, "delta_y_amplitude": 1e-11, "cycles": 2,
                 "normal_steps": 2, "tangential_steps": 2}
    case = case_from_dict(d)
    path = case.load.path()
    s = [0.5, 1, 0.5, 0, -0.5, -1, -0.5, 0, 0.5, 1] * 2
    assert path[:2] == [(0.0, 0.0, 2e-11), (0.0, 0.0, 4e-11)]
    assert path[2:] == [(2e-11 * f, 1e-11 * f, 4e-11) for f in [0.5, 1] + s[2:10] + s[2:10]]
    assert case.load.cycle_bounds() == [(3, 11), (11, 19)]
    for first, last in case.load.cycle_bounds():
        assert path[first] == path[last] == (2e-11, 1e-11, 4e-11)
    assert case_from_dict(case.to_dict()) == case
    assert "delta_x" not in case.to_dict()["load"]  # an amplitude, not a final approach
    del d["load"]["cycles"]  # one cycle by default
    assert case_from_dict(d).load.cycle_bounds() == [(3, 11)]
    d["load"]["delta_x"] = 0.0  # a zero final approach beside an amplitude is no contradiction
    assert len(case_from_dict(d).load.path()) == 2 + 2 * 5
    assert case_from_dict(paper_dict()).load.cycle_bounds() == []
    # a sweep's amplitude over a case of the default path replaces its tangential leg
    swept = case_from_dict(paper_dict()).with_overrides({"load.delta_x_amplitude": 1e-11})
    assert swept.load.cyclic and len(swept.load.path()) == 1 + 5
