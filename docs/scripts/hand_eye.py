"""Hand-eye calibration: the numbers and the figure of docs/hand-eye.md, regenerated.

python docs/scripts/hand_eye.py [--quick] [--jobs N] [--docs DIR]

1. The accuracy of ibvs.calibrate_hand_eye per mount and method (ibvs.study.hand_eye.accuracy: 20 data sets of
   12 Panda stations per measurement, noise-free, 0.3 px, a rendered tag).
2. The cost of a wrong eMc per control law (ibvs.study.hand_eye.mount_errors: the Panda case from 8 starts, eMc
   errors on a 5 x 5 grid up to 10 deg and 5 cm, 4 directions each, every scheme: 5432 episodes).
Writes DIR/figures/hand_eye_errors.png and, when DIR/hand-eye.md exists, replaces its two generated tables (between
the <!-- hand_eye:NAME --> and <!-- /hand_eye:NAME --> markers); prints both tables. DIR defaults to the docs/
folder beside this script. --quick: 2 data sets, 2 starts, 1 direction, the grid's corners (for the tests).
"""
import re
import time
from pathlib import Path

from ibvs.cli import args as cli_args
from ibvs.study import hand_eye as he


def replace(page: Path, name: str, table: str) -> None:
    text = page.read_text()
    pattern = re.compile(rf"(<!-- hand_eye:{name} -->\n).*?(\n<!-- /hand_eye:{name} -->)", re.S)
    if not pattern.search(text):
        raise SystemExit(f"{page}: no <!-- hand_eye:{name} --> ... <!-- /hand_eye:{name} --> markers")
    page.write_text(pattern.sub(lambda m: m.group(1) + table + m.group(2), text))


def main() -> None:
    parser = cli_args.Parser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a few episodes: checks that it runs")
    parser.add_argument("--jobs", type=int, default=None, help="worker processes (default: the CPUs)")
    # tried for writing when parsed, before any work (as every output path of the command line)
    cli_args.add_output(parser, "--docs", type=cli_args.out_dir, default=str(Path(__file__).resolve().parents[1]),
                        help="the docs folder")
    a = parser.parse_args()
    start = time.perf_counter()
    rows = he.accuracy(seeds=2, tag_seeds=1) if a.quick else he.accuracy(seeds=20, tag_seeds=10)
    accuracy = he.format_accuracy(rows)
    print(accuracy, f"\n\naccuracy: {time.perf_counter() - start:.0f} s\n", flush=True)
    start = time.perf_counter()
    if a.quick:
        episodes = he.mount_errors(schemes=("cartesian", "stacked"), rotations_deg=(0.0, 10.0),
                                   translations_cm=(0.0, 5.0), directions=1, starts=2, jobs=a.jobs)
        cells = ((0, 0), (10, 0), (0, 5), (10, 5))
    else:
        episodes = he.mount_errors(directions=4, starts=8, jobs=a.jobs)
        cells = ((0, 0), (2.5, 1.25), (5, 2.5), (10, 0), (0, 5), (7.5, 3.75), (10, 5))
    summary = he.summarise(episodes)
    table = he.format_mount_errors(summary, cells)
    print(table, f"\n\n{len(episodes)} episodes: {time.perf_counter() - start:.0f} s")
    (a.docs / "figures").mkdir(parents=True, exist_ok=True)
    he.figure(summary, a.docs / "figures" / "hand_eye_errors.png")
    page = a.docs / "hand-eye.md"
    if page.is_file():
        replace(page, "accuracy", accuracy)
        replace(page, "mount_errors", table)
        print(f"updated {page} and {a.docs / 'figures' / 'hand_eye_errors.png'}")


if __name__ == "__main__":
    main()
