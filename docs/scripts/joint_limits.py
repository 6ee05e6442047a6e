"""Joint-limit avoidance over random arm starts: the table of docs/arms.md, regenerated.

python docs/scripts/joint_limits.py [--starts N] [--quick] [--docs DIR]

Runs ibvs.study.joint_limits.sweep: N random starts (default 100) of the Panda and the UR5 (sim.cases.ARMS goal,
joints within +-0.8 rad of it, the target fully in the image), stacked, Cartesian and polar IBVS (gain 1, exact
depths, 15 s), each without avoidance and with ibvs.SecondaryTask's joint-limit avoidance under the classical and
the large projector. Prints the table of outcome shares and, when DIR/arms.md exists, replaces the one between its
<!-- joint_limits:shares --> and <!-- /joint_limits:shares --> markers. --quick: 2 starts (for the tests).
"""
import re
import time
from pathlib import Path

from ibvs.cli import args as cli_args
from ibvs.study import joint_limits as jl


def main() -> None:
    parser = cli_args.Parser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, default=100, help="random starts per arm")
    parser.add_argument("--quick", action="store_true", help="2 starts: checks that it runs")
    # tried for writing when parsed, before any work (as every output path of the command line)
    cli_args.add_output(parser, "--docs", type=cli_args.out_dir, default=str(Path(__file__).resolve().parents[1]),
                        help="the docs folder")
    a = parser.parse_args()
    start = time.perf_counter()
    rows = jl.sweep(("panda", "ur5"), starts=2 if a.quick else a.starts, laws=("stacked", "cartesian", "polar"))
    table = jl.format_shares(jl.shares(rows))
    print(table, f"\n\n{len(rows)} episodes: {time.perf_counter() - start:.0f} s")
    page = a.docs / "arms.md"
    if page.exists():
        text = page.read_text()
        pattern = re.compile(r"(<!-- joint_limits:shares -->\n).*?(\n<!-- /joint_limits:shares -->)", re.S)
        if not pattern.search(text):
            raise SystemExit(f"{page}: no <!-- joint_limits:shares --> ... <!-- /joint_limits:shares --> markers")
        page.write_text(pattern.sub(lambda m: m.group(1) + table + m.group(2), text))


if __name__ == "__main__":
    main()
