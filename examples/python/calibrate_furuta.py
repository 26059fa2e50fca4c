#!/usr/bin/env python3
"""Calibrates the paper's Furuta pendulum frictions from Python, on a running coordinator.

Submits ``examples/furuta/job.toml`` (the model is the built-in ``example:furuta``, which the
client finds by running ``fmucal examples`` with the binary the package installed, or
``FMUCAL_BIN``), follows its progress, prints the recovered frictions (generated with 0.010 and 0.0010) and plots the
convergence: the best objective value against evaluations, and the two frictions' best values
round by round, to a PNG.

    python examples/python/calibrate_furuta.py --coordinator http://127.0.0.1:50051 --out furuta.png

The token comes from ``--token-file``, else ``FMUCAL_TOKEN``; an ``https://`` coordinator takes
``--tls-ca`` (else ``FMUCAL_TLS_CA``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 (after choosing the backend)

from fmucal_client import Client, FmucalError, Progress  # noqa: E402

JOB = Path(__file__).resolve().parent.parent / "furuta" / "job.toml"


def arguments() -> argparse.Namespace:
    """The command line."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--coordinator", required=True, help="the coordinator's URL, e.g. http://127.0.0.1:50051")
    p.add_argument("--token-file", type=Path, help="the client token (else FMUCAL_TOKEN)")
    p.add_argument("--tls-ca", type=Path, help="CA of an https:// coordinator's certificate (else FMUCAL_TLS_CA)")
    p.add_argument("--job", type=Path, default=JOB, help=f"the job file (default {JOB})")
    p.add_argument("--out", type=Path, default=Path("furuta_convergence.png"), help="the PNG to write")
    return p.parse_args()


def plot(events: list[Progress], names: list[str], out: Path) -> None:
    """Best f against evaluations, and each parameter's best value per round."""
    batches = [e for e in events if e.evaluations > 0 and e.best_x]
    fig, (ax_f, ax_x) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax_f.semilogy([e.evaluations for e in batches], [e.best_f for e in batches], marker=".")
    ax_f.set(xlabel="evaluations", ylabel="best objective value f", title="Convergence")
    ax_f.grid(True, which="both", alpha=0.3)
    for k, name in enumerate(names):
        ax_x.plot([e.rounds for e in batches], [e.best_x[k] for e in batches], marker=".", label=name)
    for truth in (0.010, 0.0010):
        ax_x.axhline(truth, color="grey", linestyle=":", linewidth=1)
    ax_x.set(xlabel="round", ylabel="best value", title="Frictions (dotted: generated with)")
    ax_x.set_yscale("log")
    ax_x.legend()
    ax_x.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)


def main() -> int:
    args = arguments()
    with Client(args.coordinator, token_file=args.token_file, tls_ca=args.tls_ca) as client:
        job_id = client.submit(args.job)
        print(f"submitted job {job_id}")
        events = []
        for event in client.watch(job_id):
            events.append(event)
            if event.batch_wall_s > 0 and event.rounds % 5 == 0:
                print(f"  round {event.rounds:3d}  evaluations {event.evaluations:4d}  best f {event.best_f:.6e}")
        result = client.result(job_id)
    print(f"{result.status}: {result.termination}; f_opt = {result.f_opt:.6e} after {result.evaluations} "
          f"evaluations in {result.elapsed_s:.2f} s")
    # x_opt is in the order of the events' best_x: the job's calibrated values.
    for name, value in result.x_opt.items():
        print(f"  {name} = {value:.6e}")
    plot(events, list(result.x_opt), args.out)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except FmucalError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(1)
