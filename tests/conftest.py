"""Shared fixtures: real tiny Mitsuba renders for tests.

- ``compose_cfg(*overrides)``: the full Hydra config of ``conf/config.yaml`` (what ``python -m mcd.run``
  sees).
- ``store32_overrides(data_dir)``: overrides that turn the ``tiny`` profile into a 32x32, 12-frame,
  Cornell-box-only profile named ``test32`` (ref 256 spp), for quick end-to-end tests.
- ``cbox_store`` (session): ``(cfg, store)`` with every buffer of ``test32`` rendered once per session into a
  temporary folder (about 5 s on 2 cores). Tests must not modify its files; make your own store for that.
- ``cbox32`` (session): ``(scene, renderer)``: the Cornell box loaded at 32x32 in Mitsuba with a box-filter
  :class:`mcd.data.renderer.SceneRenderer` set to the scene's own camera, for direct renders.
- ``ab_sweep`` (session): the folder of one real two-job sweep ``python -m mcd.run -m +sweep=ablation
  +experiment=A,F`` on ``SWEEP32`` (its store in ``data/``, its runs in ``multirun/ablation/tiny``), run once
  for the report tests. Tests must not modify it; ``copy_sweep`` gives a private copy to change.
- ``unet_run`` (session): ``(run dir, overrides)`` of one ``python -m mcd.run +experiment=unet
  capacity=cpu`` that finished one epoch on ``cbox_store``. Tests must not modify it; copy it
  (``shutil.copytree``) to change.
- ``command_in_worker(module, argv, cwd, env)``: any ``python -m <module>`` run the same way (``mcd.run``,
  ``mcd.bundle``, ``mcd.denoise``, ``mcd.bench``), each without a new interpreter's imports (Lightning alone
  is about 5 s of CPU); ``mcd_run(*args)`` is ``mcd.run`` through it. A test whose claim is about a process
  (a lock another process holds, a kill, a read-only mount, two commands at once, a fresh interpreter's every
  line) starts the command itself. ``report_in_worker(argv, cwd)`` is ``mcd.report`` through it, an
  exception it does not turn into an exit raised in the test.

Session fixtures are what keeps the full suite short: each renders or trains once, and every test that reads
the result shares it (a test that changes files works on its own copy).

With two workers (``pytest -n 2``, ``--dist loadgroup`` in pyproject.toml) each worker has its own session
and module fixtures. So that the costly ones are made once in the suite, not once per worker, the files that
read a shared run or have a costly module fixture run on one worker each group (:data:`XDIST_GROUPS`).
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mcd.config.compose import compose
from mcd.core.paths import CONF_DIR as _CONF_DIR

CONF_DIR = str(_CONF_DIR)
# Under pytest-xdist, a worker and every command a test starts with this environment run one thread unless
# OMP_NUM_THREADS says otherwise: two workers on two cores, each with a command of two threads, spun past CI's
# timeout once (module_env() sets one thread whatever the environment says)
if os.environ.get("PYTEST_XDIST_WORKER"):
    os.environ.setdefault("OMP_NUM_THREADS", "1")
REPO = Path(__file__).resolve().parents[1]
LLVM = Path("/usr/lib/x86_64-linux-gnu/libLLVM-19.so")
#: The tiny profile cut to one 32x32 scene of 14 frames and a few training steps (the sweep of ``ab_sweep``).
SWEEP32 = [
    "data.width=32",
    "data.height=32",
    "data.segments=1",
    "data.frames_per_segment=14",
    "data.ref_spp=16",
    "data.gbuffer_spp=4",
    "data.train_scenes=[cbox]",
    "data.test_scenes=[cbox]",
    "~data.scenes.staircase2",
    "data.train_crop=32",
    "data.val_crop=32",
    "train.epochs=1",
    "train.batch_size=2",
    "train.limit_train_batches=2",
    "trainer.enable_progress_bar=false",
]
#: ``ab_sweep``'s command after ``python`` (and before ``paths.data_dir``), run in its folder: rows A and F,
#: both test frames saved as samples.
AB_SWEEP = ["-m", "mcd.run", "-m", "+sweep=ablation", "+experiment=A,F",
            f"paths.scenes_dir={REPO / 'scenes'}", *SWEEP32, "train.sample_frames=[0,1]"]


def compose_cfg(*overrides: str):
    """The composed root config with `overrides` (Hydra command-line syntax)."""
    return compose(overrides)


def store32_overrides(data_dir: Path | str) -> list[str]:
    """A 32x32 Cornell-box profile with 12 frames per sequence: 2 test, 1 validation clip, 1 training clip;
    16-pixel training crops without augmentations (the paper's protocol): a crop is a window of its frame."""
    return [
        "data=tiny",
        "data.name=test32",
        f"paths.data_dir={data_dir}",
        "data.width=32",
        "data.height=32",
        "data.segments=2",
        "data.frames_per_segment=6",
        "data.ref_spp=256",
        "data.gbuffer_spp=8",
        "data.train_scenes=[cbox]",
        "data.test_scenes=[cbox]",
        "data.train_crop=16",
        "data.val_crop=24",
        "data.augment.flips=false",
        "data.augment.transpose=false",
        "data.augment.reverse=false",
    ]


@pytest.fixture(scope="session")
def cbox_store(tmp_path_factory):
    from mcd.data import BUFFERS, StoreBuilder

    cfg = compose_cfg(*store32_overrides(tmp_path_factory.mktemp("store")))
    store = StoreBuilder.from_cfg(cfg)
    store.ensure(set(BUFFERS), progress=False)
    return cfg, store


@pytest.fixture(scope="session")
def cbox32():
    from mcd.data.mitsuba_env import select_variant

    select_variant("auto")
    import mitsuba as mi

    from mcd.data.renderer import SceneRenderer
    from mcd.data.scenes import VENDORED_DIR

    scene = mi.load_file(str(VENDORED_DIR / "cbox" / "scene.xml"), resx=32, resy=32, max_depth=6)
    params = mi.traverse(scene.sensors()[0])
    fov = float(np.asarray(params["x_fov"]).ravel()[0])
    renderer = SceneRenderer(scene, 32, 32, fov)
    renderer.set_camera(np.asarray(params["to_world"].matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0])
    return scene, renderer


#: The session fixtures that run a command (a sweep, a training): the files that read one are its group.
SHARED_RUNS = ("ab_sweep", "unet_run")
#: The test files whose tests run on one worker under ``pytest -n 2`` (group -> files), so that what they
#: share is made once in the suite rather than once per worker (docs/architecture.md "Tests"): the readers of
#: each shared run (:func:`pytest_collection_modifyitems` checks that each is listed), and each file whose own
#: module fixture trains or renders.
XDIST_GROUPS: dict[str, tuple[str, ...]] = {
    "ab_sweep": ("tests/reliability/test_bundle_run_records.py",
                 "tests/reliability/test_denoise_nonfinite_weights.py",
                 "tests/reliability/test_report_campaign11_records.py",
                 "tests/reliability/test_report_damaged_samples.py",
                 "tests/reports/test_sweep_to_report.py", "tests/reports/test_viewer.py"),
    "unet_run": ("tests/reliability/test_bundle_out.py", "tests/reliability/test_finished_runs.py",
                 "tests/reliability/test_report_out.py", "tests/reliability/test_report_paths.py",
                 "tests/reliability/test_report_stale_files.py",
                 "tests/reliability/test_transfer_identity.py"),
    "trained_f": ("tests/test_trained_f.py",),
    "bundled_f": ("tests/models/test_bundled_f.py",),
    "baselines_end_to_end": ("tests/baselines/test_end_to_end.py",),
    "run_f": ("tests/test_run.py",),
    "resume_three_epochs": ("tests/reliability/test_resume.py",),
    "run_dirs_interrupted": ("tests/reliability/test_run_dirs.py",),
    "denoise_errors": ("tests/denoise/test_errors.py",),
    "denoise_inputs": ("tests/reliability/test_denoise_inputs.py",),
    "denoise_frames": ("tests/denoise/test_frames.py",),
    "denoise_frame_scores": ("tests/denoise/test_frame_scores.py",),
    "render_statistics": ("tests/data/test_render_statistics.py",),
    "packaging_wheel": ("tests/test_packaging.py",),
}
_GROUP_OF = {file: group for group, files in XDIST_GROUPS.items() for file in files}


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Each file of :data:`XDIST_GROUPS` exists, and each test that reads a shared run (:data:`SHARED_RUNS`)
    is in a file of that run's group: a UsageError names the file otherwise."""
    if missing := [file for file in _GROUP_OF if not (REPO / file).is_file()]:
        raise pytest.UsageError(f"tests/conftest.py's XDIST_GROUPS names {missing}, which do not exist")
    for item in items:
        file = item.nodeid.split("::", 1)[0]
        for run in SHARED_RUNS:
            if run in item.fixturenames and file not in XDIST_GROUPS[run]:
                raise pytest.UsageError(f"{file} reads the shared run {run}: add it to XDIST_GROUPS[{run!r}] "
                                        "in tests/conftest.py, so that the run is made once in the suite")


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log):
    """``--dist loadgroup`` (pyproject.toml) with the groups of :data:`XDIST_GROUPS`: each group is one unit
    of work on one worker, handed out first (most tests first), then the single tests. pytest-xdist's own
    ``xdist_group`` marks are not used: with pytest 9.2 they group nothing (pytest-xdist#1386)."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class Grouped(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return _GROUP_OF.get(nodeid.split("::", 1)[0], nodeid)

    return Grouped(config, log)


def module_env() -> dict[str, str]:
    """The environment of a ``python -m mcd...`` command run by a test: this checkout first, one thread."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    if LLVM.is_file():
        env.setdefault("DRJIT_LIBLLVM_PATH", str(LLVM))
    return env


def report_in_worker(argv: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``python -m mcd.report <argv>`` in `cwd`, run in this process through :func:`command_in_worker`,
    without a new interpreter's imports of torch and pandas (about 4 s of CPU each), except that an exception
    the command does not turn into an exit is raised here, so the test fails with its traceback. A test that
    needs a real process (a wait bounded only by a timeout, a lock held by another process, every line a fresh
    interpreter writes) starts ``python -m mcd.report`` itself."""
    return command_in_worker("mcd.report", argv, cwd, raise_uncaught=True)


#: The warnings filters of a fresh interpreter (no ``-W``, not in development mode): what a command's
#: warnings meet in its own process (:func:`command_in_worker`).
FRESH_WARNING_FILTERS = (("default", DeprecationWarning, "__main__"), ("ignore", DeprecationWarning, ""),
                         ("ignore", PendingDeprecationWarning, ""), ("ignore", ImportWarning, ""),
                         ("ignore", ResourceWarning, ""))


def command_in_worker(module: str, argv: list[str], cwd: Path, env: dict[str, str] | None = None,
                      raise_uncaught: bool = False) -> subprocess.CompletedProcess:
    """``python -m <module> <argv>`` in `cwd` with `env` added to the environment, run in this process (the
    module's ``main``, what the command calls; an int it returns is the exit status, as ``sys.exit(main())``
    makes it) without a new interpreter's start and imports (Lightning alone
    is about 5 s of CPU per ``mcd.run``): the exit status, stdout and stderr a fresh interpreter gives. An
    exception the command does not turn into an exit is printed with its traceback on stderr, exit status 1,
    as the interpreter does (raised here instead with `raise_uncaught`); its warnings meet a fresh
    interpreter's filters and are written on stderr. What the command changes in the process is put back after
    it: the environment, ``sys.argv``, the folder, the root logger's handlers and level (it starts with none
    and WARNING, as in a fresh interpreter; handlers it added are closed), warnings filters, torch's thread
    count and denormal flushing, and the allocator setting of ``mcd.core.allocator``. A test whose claim needs
    a real process (another process holding a lock, a signal, a wait bounded only by a timeout, two commands
    at once) starts the command itself."""
    import importlib
    import traceback
    import warnings

    import torch
    from hydra.core.global_hydra import GlobalHydra

    from mcd.core import allocator

    command = importlib.import_module(module)
    if hasattr(command, "__path__"):  # a package: ``python -m`` runs its __main__
        command = importlib.import_module(f"{module}.__main__")
    out, err = io.StringIO(), io.StringIO()
    root = logging.getLogger()
    handlers, level = list(root.handlers), root.level
    environ, argv_before, cwd_before = dict(os.environ), list(sys.argv), Path.cwd()
    threads, policy = torch.get_num_threads(), allocator.policy()

    def to_stderr(message, category, filename, lineno, file=None, line=None) -> None:
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))

    code: int | str | None = 0
    try:
        os.environ.update(env or {})
        sys.argv = [module, *argv]
        os.chdir(cwd)
        # a fresh interpreter's root logger: no handler (pytest's capture adds its own), level WARNING, so
        # that the command's own ``logging.basicConfig`` takes effect and its log lines reach its stderr
        root.handlers[:] = []
        root.setLevel(logging.WARNING)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
            warnings.resetwarnings()
            for action, category, where in reversed(FRESH_WARNING_FILTERS):
                warnings.filterwarnings(action, category=category, module=where)
            warnings.showwarning = to_stderr
            try:
                result = command.main()
                if isinstance(result, int):  # ``sys.exit(main())``
                    code = result
            except SystemExit as exit_:
                code = exit_.code
                if isinstance(code, str):
                    print(code, file=sys.stderr)
            except Exception:  # noqa: BLE001 - what the interpreter does with it: traceback, exit status 1
                if raise_uncaught:
                    raise
                traceback.print_exc()
                code = 1
    finally:
        os.chdir(cwd_before)
        sys.argv = argv_before
        os.environ.clear()
        os.environ.update(environ)
        for handler in root.handlers:
            if handler not in handlers:
                handler.close()
        root.handlers[:] = handlers
        root.setLevel(level)
        torch.set_num_threads(threads)
        torch.set_flush_denormal(False)  # a fresh interpreter's setting; CPU training turns it on
        GlobalHydra.instance().clear()
        if allocator.policy() != policy:  # mcd.run keeps freed memory (mcd.core.allocator); glibc's default
            allocator.system_default()
    returncode = 1 if isinstance(code, str) else int(code or 0)
    return subprocess.CompletedProcess([module, *argv], returncode, out.getvalue(), err.getvalue())


def mcd_run(*args: str) -> subprocess.CompletedProcess:
    """``python -m mcd.run <args>`` from the checkout, one thread, ``HYDRA_FULL_ERROR=1``, output captured,
    run in this process (:func:`command_in_worker`)."""
    return command_in_worker("mcd.run", list(args), REPO, {"HYDRA_FULL_ERROR": "1", "OMP_NUM_THREADS": "1"})


@pytest.fixture(scope="session")
def ab_sweep(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("ab_sweep")
    proc = command_in_worker(AB_SWEEP[1], [*AB_SWEEP[2:], f"paths.data_dir={folder / 'data'}"], folder,
                             module_env())
    assert proc.returncode == 0, proc.stderr[-5000:]
    return folder


def copy_sweep(sweep_folder: Path, to: Path) -> Path:
    """A private copy of ``ab_sweep``'s folder (store and runs) in ``to``, for a test that changes it."""
    for part in ("data", "multirun"):
        shutil.copytree(sweep_folder / part, to / part, symlinks=True)
    return to


#: ``unet_run``'s settings after the store's: one epoch, no samples.
UNET_RUN = ["train.epochs=1", "train.batch_size=1", "train.sample_frames=[]",
            "trainer.enable_progress_bar=false"]


@pytest.fixture(scope="session")
def unet_run(cbox_store, tmp_path_factory) -> tuple[Path, list[str]]:
    run = tmp_path_factory.mktemp("unet_run") / "run"
    base = [*store32_overrides(cbox_store[1].data_dir), *UNET_RUN]
    proc = mcd_run("+experiment=unet", "capacity=cpu", *base, f"hydra.run.dir={run}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert (run / "metrics.json").is_file() and (run / ".hydra" / "config.yaml").is_file()
    return run, base
