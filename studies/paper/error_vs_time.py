r"""Every method on running-bond walls of growing size: error of lam against run time.

The error of a run is measured against the reference of :mod:`blockmpec.bench.compare`:
a closed form, else the certified minimum of (4) where ``milp`` proves one, else the
smallest verified multiplier of *another* method (an upper bound on the minimum);
never against a value only the run's own method produced.  Associative and
non-associative references are drawn in separate panels.
Heavy methods get time limits (``--time-limit``, default 30 s for ``milp``,
``nlp`` and ``mcp-newton``), so on larger walls they may stop without an answer:
their rows say so (status ``time_limit``) and they are absent from the figure.

Run: ``python studies/paper/error_vs_time.py [--sizes 2x2,3x3,5x4,8x5,10x8] [--time-limit 30] [--jobs N]``.
Writes ``studies/output/error_vs_time/{results.csv, results.parquet, summary.csv, error_vs_time.png,
performance_profile.png, time_vs_blocks.png}`` (the folder is replaced on each run).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import blockmpec as bm
from blockmpec.bench.compare import compare, text_table
from blockmpec.bench.plots import error_vs_time, method_style, plot_profiles
from blockmpec.bench.profiles import summary_table, summary_text

OUT = Path(__file__).resolve().parents[1] / "output" / "error_vs_time"
HEAVY = ("milp", "nlp", "mcp-newton")


def _time_vs_blocks(df, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 4.2), layout="constrained")
    for label, grp in df[df["repetition"] == 0].groupby("method_label", sort=False):
        colour, marker = method_style(label, grp["method"].iloc[0])
        ok = grp[grp["success"].astype(bool)]
        bad = grp[~grp["success"].astype(bool) & (grp["status"] != "skipped")]
        ax.plot(ok["blocks"], ok["solve_time_s"], marker=marker, color=colour, label=label)
        if len(bad):
            ax.plot(bad["blocks"], bad["solve_time_s"], ls="", marker=marker, mfc="none", color=colour)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("free blocks")
    ax.set_ylabel("solve time [s]")
    ax.grid(True, which="major", alpha=0.3)
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xticks(sorted(set(int(b) for b in df["blocks"].dropna())))
    ax.legend(frameon=False, fontsize=8, title="open marker: no success\n(time limit or unverified)", title_fontsize=7,
              loc="center left", bbox_to_anchor=(1.01, 0.5))
    ax.set_title("Solve time against wall size")
    fig.savefig(path, dpi=200)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="2x2,3x3,5x4,8x5,10x8", help="courses x blocks per course, comma-separated")
    parser.add_argument("--time-limit", type=float, default=30.0, help="seconds for milp, nlp and mcp-newton")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (timings are noisier with more)")
    parser.add_argument("--smoke", action="store_true", help="the smallest run: the 2x2 wall only (CI)")
    args = parser.parse_args(argv)
    if args.smoke:
        args.sizes = "2x2"
    cases = {}
    for size in args.sizes.split(","):
        c, b = (int(v) for v in size.lower().split("x"))
        cases[f"wall-{c}x{b}"] = ("wall", {"courses": c, "blocks_per_course": b})
    methods = [(m, m, {"time_limit": args.time_limit} if m in HEAVY else {}) for m in bm.list_solvers()]
    results: dict = {}
    df = compare(cases, methods, repeat=args.repeat, progress=not args.smoke, n_jobs=args.jobs, out=OUT, overwrite=True,
                 isolate=not args.smoke,
                 results=results)
    summary = (df.groupby(["case", "method_label"], sort=False)
                 .agg(blocks=("blocks", "first"), status=("status", "first"), multiplier=("multiplier", "first"),
                      reference=("reference", "first"), reference_source=("reference_source", "first"),
                      rel_error=("rel_error", "first"), solve_time_s=("solve_time_s", "median"))
                 .reset_index())
    summary.to_csv(OUT / "summary.csv", index=False)
    print(text_table(df, "multiplier", "{:.5f}", "Collapse multiplier", reference=True,
                     note="NA reference: f = closed form, c = certified minimum, b = best verified value of another "
                     "method (after the colon: the method that produced it)"))
    print()
    print(text_table(df, "rel_error", "{:.1e}", "Relative error of lam against the reference"))
    print()
    print(text_table(df, "solve_time_s", "{:.3g}", "Solve time [s] (median over repetitions in summary.csv)"))
    print()
    print(summary_text(summary_table(df)))
    p1 = error_vs_time(df, OUT / "error_vs_time.png", results=results,
                       title="Walls of growing size: error of lam against solve time")
    p2 = _time_vs_blocks(df, OUT / "time_vs_blocks.png")
    p3 = plot_profiles(df, OUT / "performance_profile.png")
    print(f"\nwrote {OUT / 'results.csv'}, {p1.name}, {p2.name}, {p3.name}")
    return df


if __name__ == "__main__":
    main()
