"""Shared by the sessions' experiment scripts: ``GEN:LO-HI`` arguments to (generator, seed) jobs, and
the two-worker process pool that runs them (sessions 32-35 each wrote this block again; their
archived scripts are kept as they ran).

Usage from a script in ``data/calibration_benchmark/sessionNN_*/``::

    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent / "tools"))
    from jobs import map_jobs, seed_jobs
"""
from concurrent.futures import ProcessPoolExecutor

#: The record generators by the name the scripts' arguments use.
GEN = {"independent": "plant.calibration.bench_records", "blind": "plant.calibration.blind_records"}


def seed_jobs(specs):
    """``["independent:10-12", "blind:5-5"]`` → ``[("independent", 10), ("independent", 11), ...]``.

    Raises ValueError naming the argument when it is not ``GEN:LO-HI`` with a known generator."""
    jobs = []
    for spec in specs:
        try:
            gen, rng = spec.split(":")
            lo, hi = map(int, rng.split("-"))
        except ValueError:
            raise ValueError(f"{spec!r}: expected GEN:LO-HI, e.g. independent:10060-10659") from None
        if gen not in GEN:
            raise ValueError(f"{spec!r}: unknown generator {gen!r}; expected one of {sorted(GEN)}")
        jobs += [(gen, s) for s in range(lo, hi + 1)]
    return jobs


def map_jobs(fn, jobs, chunksize=4, workers=2):
    """``fn`` over ``jobs`` in a process pool (2 workers: these machines have 2 cores), results in
    job order, ``None`` results dropped."""
    with ProcessPoolExecutor(workers) as ex:
        return [o for o in ex.map(fn, jobs, chunksize=chunksize) if o is not None]
