"""Every method of the benchmark, one entry each (docs/architecture.md, "Methods"): its experiment, the name
tables and legends show, its config, whether it trains, the paper's numbers for it, its place in Table 1 and
in the benchmarks. Each entry is written beside its method's factory (``ENTRIES`` in the factory's module,
:data:`FACTORY_MODULES`) and read from there without importing torch. Tables, reports, the bench and
``python -m mcd.complexity`` derive from :data:`CATALOGUE`; nothing else lists methods.

The paper's numbers (docs/benchmark.md "The paper's numbers") are data here: Table 1 in each entry's
``paper``, the component study A-M in :data:`COMPONENTS` (whose switches are read from the rows' config
files). Mitsuba scenes, 4 spp, 1920x1080; PSNR dB, SSIM x1e2, L_t x1e2, rMSE x1e3, GMACs, M params.

What a method reads (its buffers) is declared by its model (``required_buffers()``), not here.
"""

from __future__ import annotations

import ast
import functools
from dataclasses import dataclass
from pathlib import Path

import yaml

from mcd.core.paths import CONF_DIR, PACKAGE_DIR
from mcd.models.switches import SWITCHES

#: The models' folder: the factories and, beside each, its catalogue entries.
MODELS_DIR = PACKAGE_DIR / "models"


def _yaml(path: Path) -> dict:
    return yaml.safe_load(path.read_text()) or {}


@functools.cache
def experiment_method(experiment: str) -> str:
    """The ``method.name`` experiment ``experiment`` runs, as its file chooses it: the method file of its
    ``defaults`` (``override /method: <name>``), else the root config's (``conf/config.yaml``: ``two_stage``,
    the rows A-M and the variants of F)."""
    for entry in _yaml(CONF_DIR / "experiment" / f"{experiment}.yaml").get("defaults") or []:
        if isinstance(entry, dict) and "override /method" in entry:
            return str(entry["override /method"])
    return next(str(e["method"]) for e in _yaml(CONF_DIR / "config.yaml")["defaults"]
                if isinstance(e, dict) and "method" in e)


@functools.cache
def method_trainable(method: str) -> bool:
    """Whether method ``method`` has weights to train: its ``conf/method/<method>.yaml``'s ``trainable``
    (true where the file does not set it), the key ``mcd.run`` reads."""
    return bool(_yaml(CONF_DIR / "method" / f"{method}.yaml").get("trainable", True))


@dataclass(frozen=True)
class Method:
    """One method of the benchmark.

    ``experiment``: ``+experiment=<experiment>`` (``conf/experiment/<experiment>.yaml``); ``display``: its
    name in tables and legends; ``paper``: Table 1's numbers (psnr, ssim, gmacs, params_m) or None;
    ``table1``: a row of Table 1 (in :data:`CATALOGUE`'s order); ``variant_of``: the Table 1 row it varies
    (same paper numbers, shown after it, only where it ran); ``stand_in``: the experiment whose run stands in
    where this one has none (the same network); ``bench``: measured by default by ``python -m mcd.bench``;
    ``train_bench``: measured by default by ``python -m mcd.bench train``; ``diagnostic``: a variant that asks
    which input carries a method's score, not a method of the paper's or a baseline's (docs/method.md
    "Diagnostics"): findings do not count it as a baseline. Its ``method`` and whether it is ``trainable``
    are read from its config files, the one place each is written.
    """

    experiment: str
    display: str
    paper: dict[str, float] | None = None
    table1: bool = False
    variant_of: str | None = None
    stand_in: str | None = None
    bench: bool = False
    train_bench: bool = False
    diagnostic: bool = False

    @property
    def method(self) -> str:
        """``method.name`` (``conf/method/<method>.yaml``, the model registry's name):
        :func:`experiment_method`."""
        return experiment_method(self.experiment)

    @property
    def trainable(self) -> bool:
        """It has weights to train: :func:`method_trainable` of its method."""
        return method_trainable(self.method)


#: The factories' modules under ``mcd/models/``, in Table 1's order: each declares its method's entries
#: (``ENTRIES``) beside its factory, the one place each is written (docs/architecture.md "Methods").
FACTORY_MODULES: tuple[str, ...] = ("baselines/unet.py", "baselines/fastdvdnet.py", "baselines/rae.py",
                                    "baselines/dasr.py", "baselines/ntasad.py", "two_stage.py",
                                    "baselines/oidn.py", "baselines/noisy.py")


def entries_assignment(path: Path) -> ast.Assign | None:
    """The module-level ``ENTRIES = ...`` of the Python file ``path``, read from its source, or None."""
    return next((node for node in ast.parse(path.read_text(), str(path)).body if isinstance(node, ast.Assign)
                 and [getattr(t, "id", None) for t in node.targets] == ["ENTRIES"]), None)


def module_entries(path: Path) -> tuple[Method, ...]:
    """The entries a factory's module declares (its ``ENTRIES``: a tuple of literal dicts of
    :class:`Method`'s fields), read from its source without importing it, so that the catalogue needs no
    torch (docs/architecture.md "Start-up"). ValueError naming the file where ``ENTRIES`` is missing, not
    literal, or has a field :class:`Method` does not know."""
    node = entries_assignment(path)
    try:
        if node is None:
            raise ValueError("no module-level ENTRIES")
        return tuple(Method(**entry) for entry in ast.literal_eval(node.value))
    except (ValueError, TypeError) as err:
        raise ValueError(f"{path}: its ENTRIES are a tuple of literal dicts of mcd.config.methods.Method's "
                         f"fields ({err})") from None


#: Every method, Table 1's rows in the paper's order first (:data:`FACTORY_MODULES`). Rows A-M of the
#: component study are the ``two_stage`` method with switches (:data:`COMPONENTS`); F, the full method, is
#: also Table 1's "Ours".
CATALOGUE: tuple[Method, ...] = tuple(entry for module in FACTORY_MODULES
                                      for entry in module_entries(MODELS_DIR / module))
#: Experiment -> its entry.
BY_EXPERIMENT: dict[str, Method] = {m.experiment: m for m in CATALOGUE}
#: Table 1's rows, in the paper's order, then the two references it does not print (OIDN, the noisy input).
TABLE1_ROWS: tuple[str, ...] = tuple(m.experiment for m in CATALOGUE if m.table1)
#: A variant of a Table 1 row (experiment -> the row it varies).
TABLE1_VARIANTS: dict[str, str] = {m.experiment: m.variant_of for m in CATALOGUE if m.variant_of}
#: Table 1's trained baselines (trainable rows other than the paper's own method).
TRAINED_BASELINES: tuple[str, ...] = tuple(m.experiment for m in CATALOGUE
                                           if m.table1 and m.trainable and m.method != "two_stage")
#: The variants of Table 1's trained baselines that findings count as baselines (not the diagnostics).
BASELINE_VARIANTS: tuple[str, ...] = tuple(m.experiment for m in CATALOGUE
                                           if m.variant_of in TRAINED_BASELINES and not m.diagnostic)
#: Table 1 by ``method.name``: the paper's numbers of each method it prints.
TABLE1: dict[str, dict[str, float]] = {m.method: m.paper for m in CATALOGUE if m.table1 and m.paper}


def display_name(experiment: str) -> str:
    """The name tables and legends show for an experiment (rows A-M other than F show as their letter)."""
    entry = BY_EXPERIMENT.get(experiment)
    return entry.display if entry is not None else experiment


#: The paper's component study (Sec. 5.3), its numbers per row: PSNR, SSIM x1e2, L_t x1e2, rMSE x1e3, GMACs,
#: M params. Which switches each row has is its config file's alone (:func:`row_switches`).
_COMPONENT_NUMBERS = """
A 31.92 86.00 2.51 5.58 316.52 0.972
B 32.13 86.81 2.52 5.09 464.87 1.348
C 33.11 87.31 2.27 4.03 526.05 1.471
D 33.29 87.51 2.17 3.79 526.40 1.471
E 33.34 87.56 2.18 3.70 478.54 1.324
F 33.39 87.65 2.16 3.67 478.22 1.285
G 33.22 87.33 2.20 3.89 478.34 1.324
H 33.19 87.36 2.22 3.90 478.02 1.284
I 33.15 87.40 2.22 4.00 525.94 1.432
J 33.14 87.29 2.25 4.06 525.74 1.432
K 32.46 86.94 2.43 4.73 465.07 1.348
L 32.43 86.88 2.43 4.72 439.43 1.269
M 32.39 87.02 2.48 4.68 464.56 1.309
"""


def row_switches(row: str) -> dict[str, bool]:
    """The six switches of component row ``row`` as its experiment file, ``conf/experiment/<row>.yaml``, sets
    them: the one place a row's switches are written (the file every run of the row composes). ValueError
    naming the file where it does not set each switch to true or false."""
    path = CONF_DIR / "experiment" / f"{row}.yaml"
    method = (yaml.safe_load(path.read_text()) or {}).get("method") or {}
    if set(method) != set(SWITCHES) or not all(isinstance(v, bool) for v in method.values()):
        raise ValueError(f"{path}: a component row's file sets method.{{{','.join(SWITCHES)}}} to true or "
                         f"false and no other method key; it sets {sorted(method)}")
    return {s: method[s] for s in SWITCHES}


def _components() -> dict[str, dict]:
    rows = {}
    for line in _COMPONENT_NUMBERS.strip().splitlines():
        name, psnr, ssim, lt, rmse, gmacs, params = line.split()
        rows[name] = {"switches": row_switches(name),
                      "psnr": float(psnr), "ssim": float(ssim), "lt": float(lt), "rmse": float(rmse),
                      "gmacs": float(gmacs), "params_m": float(params)}
    return rows


#: Component study A-M: each row's switches (from its file, :func:`row_switches`) and the paper's numbers for
#: it, PSNR, SSIM x1e2, L_t x1e2, rMSE x1e3, GMACs, M params. Each row's experiment,
#: ``conf/experiment/<row>.yaml``, is row F's method with the row's switches and nothing else
#: (tests/test_experiments.py); ``tests/models/test_complexity.py`` holds each row's counted size under the
#: ``paper`` capacity profile to the paper's.
COMPONENTS: dict[str, dict] = _components()


def paper_complexity(experiment: str, method: str | None = None) -> dict[str, float] | None:
    """``{"params_m", "gmacs"}`` the paper reports for an experiment (A-M) or, failing that, for a method of
    Table 1 (by ``method.name``); ``None`` when the paper has no number (e.g. the noisy input, OIDN)."""
    row = COMPONENTS.get(experiment) or TABLE1.get(experiment) or (TABLE1.get(method) if method else None)
    if row is None:
        return None
    return {"params_m": row["params_m"], "gmacs": row["gmacs"]}
