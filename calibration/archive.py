"""The archive of every evaluated individual: genes, observables, errors and fitness, one record each.

It is the calibration's memory: an individual already in the archive is never simulated again (so a resumed or
repeated calibration replays its history at no cost), and a later calibration of the same rig can load it and start
from what is known (the paper proposes such archives as the basis of faster future calibrations). Records are keyed
by their exact gene values; the archive also holds the problem's simulation key (rig, scale, time step, device
class), and it refuses to serve records made with a different one. Errors and fitness are recomputed from the
stored observables when the targets differ.
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from warpdem.files import write_text_atomic


def same_or_extended(saved: dict, current: dict, defaults: dict) -> bool:
    """Whether a saved set of parameters (a run folder's) names the same run as ``current``: equal in every saved
    key, and every key that ``current`` adds (an option added since the folder was made) at its value in
    ``defaults``."""
    return (set(saved) <= set(current) and all(saved[k] == current[k] for k in saved)
            and all(k in defaults and current[k] == defaults[k] for k in current if k not in saved))


def write_json_atomic(path: str | Path, data: object) -> None:
    """Write JSON through a temporary file and a rename: a run killed while writing leaves the old file intact."""
    write_text_atomic(path, json.dumps(data, indent=1))


@dataclass
class Record:
    """One evaluated individual. ``genes``: name -> value [SI]; ``observables``: name -> value (NaN where the
    simulation gave none); ``errors``: name -> relative error [-]; ``fitness`` as the GA saw it."""

    index: int
    generation: int
    stage: str
    genes: dict[str, float]
    observables: dict[str, float]
    errors: dict[str, float] = field(default_factory=dict)
    fitness: float = 0.0
    batch: int = 0
    """which batched simulation evaluated it (records of one batch were worlds of one simulation)."""
    failure: str = ""
    """why its simulation gave no observables (it went unstable: the SimulationError's message); "" when it ran."""

    def gene_vector(self, names: Sequence[str]) -> tuple[float, ...]:
        return tuple(float(self.genes[n]) for n in names)


class Archive:
    """Records of one problem's simulations, in evaluation order.

    Args:
        gene_names: the genes, in the order of a gene vector.
        simulation_key: what the observables depend on besides the genes (JSON-able); records are only reused
            under an equal key.
    """

    def __init__(self, gene_names: Sequence[str], simulation_key: dict[str, object]) -> None:
        self.gene_names = tuple(gene_names)
        self.simulation_key = json.loads(json.dumps(simulation_key))
        self.records: list[Record] = []
        self._index: dict[tuple[float, ...], int] = {}
        self.n_batches = 0

    def __len__(self) -> int:
        return len(self.records)

    def __iter__(self) -> Iterator[Record]:
        return iter(self.records)

    def key(self, values: Sequence[float]) -> tuple[float, ...]:
        return tuple(float(v) for v in values)

    def get(self, values: Sequence[float]) -> Record | None:
        k = self._index.get(self.key(values))
        return None if k is None else self.records[k]

    def add(self, record: Record) -> None:
        k = self.key(record.gene_vector(self.gene_names))
        if k in self._index:
            raise ValueError(f"individual {dict(zip(self.gene_names, k, strict=True))} is already archived")
        self._index[k] = len(self.records)
        self.records.append(record)

    def best(self, stage: str | None = None) -> Record:
        recs = [r for r in self.records if stage is None or r.stage == stage]
        if not recs:
            raise ValueError("the archive holds no records")
        return max(recs, key=lambda r: r.fitness)

    def column(self, name: str) -> np.ndarray:
        """Values of a gene, observable, error or ``fitness`` over all records (n_records,)."""
        out = []
        for r in self.records:
            for d in (r.genes, r.observables, r.errors):
                if name in d:
                    out.append(d[name])
                    break
            else:
                out.append(r.fitness if name == "fitness" else np.nan)
        return np.asarray(out, dtype=np.float64)

    def to_dict(self) -> dict[str, object]:
        return {"gene_names": list(self.gene_names), "simulation_key": self.simulation_key,
                "n_batches": self.n_batches, "records": [asdict(r) for r in self.records]}

    def save(self, path: str | Path) -> None:
        """Write JSON atomically (a run killed while writing leaves the previous file intact). NaN is written as
        JSON's NaN literal (Python reads it back)."""
        write_json_atomic(path, self.to_dict())

    @classmethod
    def load(cls, path: str | Path) -> Archive:
        d = json.loads(Path(path).read_text())
        a = cls(d["gene_names"], d["simulation_key"])
        a.n_batches = int(d.get("n_batches", 0))
        for r in d["records"]:
            a.add(Record(**r))
        return a

    def merge(self, other: Archive) -> int:
        """Add the records of ``other`` (same genes and simulation key) that this archive lacks; returns how many."""
        if other.gene_names != self.gene_names:
            raise ValueError(f"archive genes {other.gene_names} differ from this calibration's {self.gene_names}")
        if other.simulation_key != self.simulation_key:
            raise ValueError("the archive was made with a different simulation (rig, scale, time step): "
                             f"{other.simulation_key} vs {self.simulation_key}")
        n = 0
        for r in other.records:
            if self.get(r.gene_vector(self.gene_names)) is None:
                self.add(Record(**{**asdict(r), "index": len(self.records), "stage": "archive",
                                   "generation": -1}))
                n += 1
        return n
