"""The same study on a Dask cluster: a LocalCluster here, or the address of a running ``dask scheduler``
(start one with ``dask scheduler`` and workers with ``dask worker tcp://host:8786``). The rows are the same
floats as a serial run.

    python examples/dask_cluster_study.py --rom build/rom [--scheduler tcp://host:8786]
    python examples/dask_cluster_study.py --data data [--scheduler tcp://host:8786]
"""

import argparse
import sys
from pathlib import Path

from distributed import Client, LocalCluster

from pipeline.runners import Dask

sys.path.insert(0, str(Path(__file__).parent))
from own_superelement_study import add_source_arguments, run_study, structures_from  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_source_arguments(parser)
    parser.add_argument("--scheduler", help="scheduler address (default: a LocalCluster of two workers)")
    parser.add_argument("--out", type=Path, default=Path("results/example-dask-study"))
    arguments = parser.parse_args(argv)
    if arguments.scheduler:
        client = Client(arguments.scheduler)
    else:
        client = Client(LocalCluster(n_workers=2, threads_per_worker=1, processes=True))
    with client:
        return run_study(structures_from(arguments), arguments.designs, arguments.out, Dask(client))


if __name__ == "__main__":
    main()
