"""The solver from Python (``import smokelab``) against the release binary:
the same steps give the same bits as ``smokelab run``, bad input raises
``ValueError`` with the command line's message, stepping releases the GIL
and stops on Ctrl-C, and a long run holds its memory.
"""

import _thread
import pydoc
import re
import subprocess
import threading
import time

import numpy as np
import pytest

import smokelab

from conftest import smokelab as smokelab_cli
from conftest import smokelab_bin

MODES = ["gridded", "gridless", "selma"]


def cli_error(*args) -> str:
    """The one-line error of ``smokelab ARGS``, which must exit 2."""
    done = subprocess.run([str(smokelab_bin()), *map(str, args)], capture_output=True, text=True)
    assert done.returncode == 2, done.stderr
    assert done.stderr.startswith("error: "), done.stderr
    return done.stderr[len("error: "):].strip()


@pytest.mark.parametrize("mode", MODES)
def test_n_steps_equal_the_runs_saved_frame_bit_for_bit(tmp_path, mode):
    """``step()`` N times is the run's frame N: ``--frames N --save-every N``
    saves it once, the gases and the staggered velocity, whatever the mode."""
    n, keys = 6, dict(res=16, gravity=10, density=mode)
    out = tmp_path / "run"
    smokelab_cli(
        "run", "hot-cold", "--res", 16, "--gravity", 10, "--density", mode,
        "--frames", n, "--save-every", n, "--quiet", "--out", out,
    )
    sim = smokelab.Simulation("hot-cold", **keys)
    for _ in range(n - 1):
        sim.step()
    sim.step(1)
    assert (sim.steps, sim.time) == (n, np.float32(n) * np.float32(0.05))
    fields = sim.fields()
    assert sorted(fields) == ["cold", "hot", "u", "v", "w"]
    for name, array in fields.items():
        saved = np.load(out / f"{name}_{n:04d}.npy")
        assert array.dtype == np.float32 and array.flags.c_contiguous
        assert array.shape == saved.shape, name
        assert np.array_equal(array, saved), f"{name} differs from the run's frame {n}"
    assert fields["hot"].max() > 0.1, "the hot gas was injected"


def smooth_blob(n: int) -> np.ndarray:
    """A density off every symmetry of the prescribed flows, f64."""
    z, y, x = np.meshgrid(*(np.arange(n) + 0.5,) * 3, indexing="ij")
    r2 = (x - 0.3 * n) ** 2 + (y - 0.55 * n) ** 2 + (z - 0.45 * n) ** 2
    return np.exp(-r2 / (0.05 * n * n)) + 0.1 * np.sin(x / 3.0)


@pytest.mark.parametrize("mode", MODES)
def test_set_density_then_steps_equal_the_runs_initial_file(tmp_path, mode):
    """``set_density`` before stepping is ``--initial FILE``: the f64 array
    rounded to f32 as the file is, the same frames after four steps."""
    n, res = 4, 16
    blob = smooth_blob(res)
    np.save(tmp_path / "initial.npy", blob)
    out = tmp_path / "run"
    smokelab_cli(
        "run", "deformation", "--res", res, "--density", mode, "--initial", tmp_path / "initial.npy",
        "--frames", n, "--save-every", n, "--quiet", "--out", out,
    )
    sim = smokelab.Simulation("deformation", res=res, density=mode)
    sim.set_density("density", blob)
    if mode == "gridded":  # gridless averages 2×2×2 points of a cell
        assert np.array_equal(sim.fields()["density"], blob.astype(np.float32))
    sim.step(n)
    assert np.array_equal(sim.fields()["density"], np.load(out / f"density_{n:04d}.npy"))


def test_set_density_refuses_a_wrong_shape_nan_and_an_unknown_gas():
    sim = smokelab.Simulation("hot-cold", res=16)
    with pytest.raises(ValueError, match=r"shape \[16, 16, 8\]; this simulation's grid is \(nz, ny, nx\) = \(16, 16, 16\)"):
        sim.set_density("hot", np.zeros((16, 16, 8)))
    bad = np.zeros((16, 16, 16))
    bad[1, 2, 3] = np.nan
    bad[4, 5, 6] = np.inf
    with pytest.raises(ValueError, match=r"2 values are not finite \(the first at \[z, y, x\] = \[1, 2, 3\]\)"):
        sim.set_density("hot", bad)
    with pytest.raises(ValueError, match="no gas 'smoke'; this simulation's gases are hot, cold"):
        sim.set_density("smoke", np.zeros((16, 16, 16)))
    assert sim.fields()["hot"].max() == 0.0, "a refused array changed nothing"


def test_set_density_on_a_running_gridded_gas_is_what_it_steps_from():
    """Mid-run, the gridded density is replaced and stepped on from there."""
    a = smokelab.Simulation("hot-cold", res=16, gravity=10)
    a.step(3)
    b = smokelab.Simulation("hot-cold", res=16, gravity=10)
    b.step(3)
    hot = a.fields()["hot"]
    b.set_density("hot", np.zeros_like(hot))
    b.set_density("hot", hot)
    a.step(2)
    b.step(2)
    assert np.array_equal(a.fields()["hot"], b.fields()["hot"])


#: (scenario, keys, what the message must say), each refused before any work.
BAD = [
    ("hot-cold", {"resolution": 32}, "unknown key 'resolution' in --set; hot-cold has the keys"),
    ("hot-cold", {"res": 2}, "resolution 2 is too small"),
    ("hot-cold", {"res": -4}, "res = -4 (--set) is not a valid hot-cold value"),
    ("hot-cold", {"res": "big"}, 'res = "big" (--set) is not a valid hot-cold value'),
    ("hot-cold", {"dt": 0.0}, "dt"),
    ("hot-cold", {"nu": float("nan")}, "nu"),
    ("hot-cold", {"density": "fog"}, "density = \"fog\" (--set)"),
    ("hot-cold", {"wall": 1.2}, "'wall' (--set) applies to slab-box only; hot-cold has no such parameter"),
    ("hot-cold", {"selma_remap": 1.0}, "selma_remap 1 is only used by --density selma"),
    ("hot-cold", {"box": "closed", "density": "gridless"}, "box closed needs density gridded"),
    ("hot-cold", {"threads": 0}, "threads"),
    ("slab-box", {"period": 2.0}, "'period' (--set) applies to deformation, zalesak only"),
]


@pytest.mark.parametrize("scenario,keys,message", BAD)
def test_a_bad_key_or_value_raises_the_command_lines_message(scenario, keys, message):
    with pytest.raises(ValueError) as raised:
        smokelab.Simulation(scenario, **keys)
    assert message in str(raised.value)
    # Word for word what `smokelab run SCENARIO --set KEY=VALUE …` says.
    sets = []
    for key, value in keys.items():
        text = {float("nan"): "nan"}.get(value, value) if isinstance(value, float) else value
        sets += ["--set", f"{key}={text}"]
    assert str(raised.value) == cli_error("run", scenario, *sets, "--print-config")


@pytest.mark.parametrize("scenario", smokelab.scenarios())
def test_every_key_of_every_scenario_refuses_a_value_of_no_type_and_names_the_key(scenario):
    keys = smokelab.keys(scenario)
    assert len(keys) > 20
    for key, _default, _help in keys:
        with pytest.raises(ValueError, match=re.escape(key)):
            smokelab.Simulation(scenario, **{key: [["not", "a"], "value"]})
        with pytest.raises(ValueError, match=re.escape(key)):
            smokelab.Simulation(scenario, **{key: object()})


def test_an_unknown_scenario_is_named_with_the_known_ones():
    with pytest.raises(ValueError, match="unknown scenario 'hot'; the scenarios are hot-cold, slab-box, deformation"):
        smokelab.Simulation("hot")


def test_config_is_the_resolved_configuration_and_help_lists_the_keys():
    sim = smokelab.Simulation("hot-cold", res=16, density="gridless", hot_center=[4, 2, 5])
    assert sim.config["res"] == 16 and sim.config["density"] == "gridless"
    assert sim.config["hot_center"] == [4.0, 2.0, 5.0]
    assert sim.gases == ["hot", "cold"] and sim.scenario == "hot-cold"
    doc = pydoc.render_doc(smokelab.Simulation, renderer=pydoc.plaintext)
    for text in ["hot_center", "density [\"gridded\"]", "wall", "step(", "set_density("]:
        assert text in doc, text


def test_checkpoint_and_resume_step_on_bit_for_bit(tmp_path):
    for mode in ["gridded", "gridless"]:
        sim = smokelab.Simulation("hot-cold", res=16, gravity=10, density=mode)
        sim.step(3)
        sim.checkpoint(tmp_path / f"{mode}.ckpt")
        sim.step(3)
        resumed = smokelab.Simulation.resume(tmp_path / f"{mode}.ckpt")
        assert resumed.steps == 3 and resumed.config == sim.config
        resumed.step(3)
        a, b = sim.fields(), resumed.fields()
        assert all(np.array_equal(a[k], b[k]) for k in a), mode
    (tmp_path / "junk.ckpt").write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="is not a smokelab checkpoint"):
        smokelab.Simulation.resume(tmp_path / "junk.ckpt")


def test_render_is_an_rgb_image_of_the_gases():
    sim = smokelab.Simulation("hot-cold", res=16, gravity=10)
    empty = sim.render(width=40, height=30)
    assert empty.shape == (30, 40, 3) and empty.dtype == np.uint8
    sim.step(5)
    image = sim.render(40, 30)
    # The hot gas is drawn red, the cold blue, where there was background.
    changed = np.any(image != empty, axis=2)
    assert changed.sum() > 20
    with pytest.raises(ValueError, match="image width is 0"):
        sim.render(0, 30)


def test_run_writes_what_the_command_line_writes(tmp_path):
    keys = ["--res", 16, "--frames", 4, "--save-every", 2, "--gravity", 10]
    smokelab_cli("run", "hot-cold", *keys, "--quiet", "--out", tmp_path / "cli")
    out = smokelab.run("hot-cold", out=tmp_path / "py", res=16, frames=4, save_every=2, gravity=10)
    assert out == tmp_path / "py"
    files = sorted(p.name for p in (tmp_path / "cli").iterdir())
    assert files == sorted(p.name for p in out.iterdir())
    for name in [f for f in files if f.endswith(".npy")]:
        assert np.array_equal(np.load(out / name), np.load(tmp_path / "cli" / name)), name
    run = smokelab.xr.open_run(out)
    assert list(run.volumes.step.values) == [2, 4]
    with pytest.raises(ValueError, match="holds 16 files an earlier smokelab wrote"):
        smokelab.run("hot-cold", out=out, res=16, frames=4)


def test_steps_hold_their_memory():
    """1,000 steps at 16³, reading the fields after each, grow the resident
    set by less than a tenth of what keeping one step's arrays would."""

    def rss() -> int:
        with open("/proc/self/status") as status:
            return next(int(line.split()[1]) for line in status if line.startswith("VmRSS:")) * 1024

    sim = smokelab.Simulation("hot-cold", res=16)
    for _ in range(100):
        sim.step()
        sim.fields()
    before = rss()
    for _ in range(1000):
        sim.step()
        sim.fields()
    grown = rss() - before
    per_step = 5 * 16**3 * 4
    assert grown < 100 * per_step, f"grew {grown} bytes over 1000 steps"


def test_another_thread_runs_while_step_does():
    """``step(50)`` is one call; without releasing the GIL no other Python
    thread could run until it returned. Ticks of a counting thread land
    throughout the call."""
    sim = smokelab.Simulation("hot-cold", res=24)
    sim.step()
    ticks, stop = [], threading.Event()

    def count():
        while not stop.wait(0.002):  # waits without the GIL, ticks with it
            ticks.append(time.perf_counter())

    counter = threading.Thread(target=count)
    counter.start()
    time.sleep(0.05)
    start = time.perf_counter()
    sim.step(50)
    end = time.perf_counter()
    stop.set()
    counter.join()
    span = end - start
    inside = [t for t in ticks if start + 0.1 * span < t < end - 0.1 * span]
    # Ticks in each tenth of the middle of the call.
    tenths = {int((t - start) / span * 10) for t in inside}
    assert tenths == set(range(1, 9)), (span, sorted(tenths))


def test_ctrl_c_stops_a_long_step_between_steps():
    sim = smokelab.Simulation("hot-cold", res=16)
    threading.Timer(0.3, _thread.interrupt_main).start()
    with pytest.raises(KeyboardInterrupt):
        sim.step(1_000_000)
    assert 0 < sim.steps < 1_000_000
    fields = sim.fields()
    assert np.isfinite(fields["hot"]).all()
    sim.step()


def test_the_xarray_reader_comes_along():
    import smokelab_xr

    assert smokelab.xr.open_run is smokelab_xr.open_run
