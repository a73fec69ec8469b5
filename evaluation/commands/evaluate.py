"""``pfpeople-eval evaluate``: the A/B evaluation of the filters on a scenario (the README's main job)."""

from __future__ import annotations

import argparse
from pathlib import Path

from evaluation.harness.ab import FilterSpec, default_filters, format_table, particles_label, run_ab, table_key
from evaluation.scenarios.scenario import Scenario, builtin_scenarios
from pfpeople.cli.support import examples


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "evaluate",
        epilog=examples(
            "pfpeople-eval evaluate --scenario complementary --out runs/evaluate",
            "pfpeople-eval evaluate --scenario corridor --particles 5000 50000",
        ),
        help="A/B evaluation of the grid and particle filters on a scenario with ground truth",
        description="Run the grid filter (paper and linear forms) and the particle filter on the same simulated "
        "detections; print the paper's Table 2 layout plus grid scores; write run.json and Fig. 6-style PNGs.",
    )
    p.add_argument(
        "--scenario",
        default="complementary",
        help=f"built-in scenario ({', '.join(builtin_scenarios())}) or a TOML file (default: complementary)",
    )
    p.add_argument("--frames", type=int, default=None, help="number of frames (default: the scenario's)")
    p.add_argument("--seed", type=int, default=None, help="scenario seed (default: the scenario's)")
    p.add_argument(
        "--particles",
        type=int,
        nargs="*",
        default=[5_000, 50_000],
        help="particle counts of the particle-filter rows (default: 5000 50000; none: grid only; >= 1 per cell)",
    )
    p.add_argument("--persistent", action="store_true", help="add a particle filter with velocity-persistent walkers")
    p.add_argument("--pf-seed", type=int, default=0, help="seed of the particle filters (default 0)")
    p.add_argument("--gate", type=float, default=0.5, help="matching distance (m) for recall/precision (0.5)")
    p.add_argument("--figure-frames", type=int, nargs="*", default=None, help="frames to draw (default: two)")
    p.add_argument("--out", type=Path, default=Path("runs/evaluate"), help="output folder (default runs/evaluate)")
    p.add_argument("--no-progress", action="store_true", help="no progress bars")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.frames is not None and args.frames < 1:
        raise ValueError(f"--frames must be positive, got {args.frames}")
    scenario = Scenario.from_name(args.scenario, n_frames=args.frames, seed=args.seed)
    filters = default_filters(args.particles)
    if args.persistent:
        n = max(args.particles) if args.particles else 10_000
        filters.append(
            FilterSpec(
                name=f"{particles_label(n)} persistent",
                kind="particle",
                n_particles=n,
                motion_model="persistent",
            )
        )
    n_frames = len(scenario)
    if args.figure_frames is None:  # two middle frames (one when the scenario has a single frame)
        figure_frames = sorted({n_frames // 2, min(n_frames // 2 + 1, n_frames - 1)})
    else:
        figure_frames = args.figure_frames
    result = run_ab(
        scenario,
        filters,
        gate=args.gate,
        figure_frames=figure_frames,
        out_dir=args.out,
        seed=args.pf_seed,
        progress=not args.no_progress,
    )
    print(format_table(result))
    print()
    print(table_key(args.gate))
    print()
    for r in result.filters:
        t = r.tracking
        if t.get("tracked_fraction") is not None:
            print(
                f"tracking on {r.name}: person {t.get('person_id')} from frame {t.get('start_frame')}, "
                f"tracked {t['tracked_fraction']:.2f} of {t['frames']} frames, "
                f"held while every detector missed: {t['held_while_all_missed']}/{t['all_missed_frames']}, "
                f"median error {t['median_error_m']:.2f} m"
            )
    print(f"\nrun record: {result.record_path}")
    print(f"figures ({len(result.figure_paths)}): {args.out}/fig6_*.png")
    return 0
