"""The command line of `orchestrate.reference`: its arguments and what the command does with them."""
from __future__ import annotations

from pathlib import Path

from orchestrate.freefem import REPO
from orchestrate import formats, parameters
from orchestrate.outputs import claim_file, write_text
from orchestrate.reference import MARK, PAGE, page

NAME, HELP = ("reference", "write docs/scene-format.md, the scene format's reference, from the schema, and the files "
              "generated from edp/lib/parameters.toml (docs/parameters.md, edp/lib/parameterTable.idp, edp/lib/schemes.idp) "
              "and edp/lib/formats.toml (docs/formats.md, edp/lib/formatTable.idp, edp/lib/stateFile.idp), with the "
              "default --out only")


def add_arguments(parser) -> None:
    parser.add_argument("--out", default=str(PAGE), help=f"where to write it (default {PAGE.relative_to(REPO)}); an "
                                                         "existing file is replaced only with --force")
    parser.add_argument("--force", action="store_true",
                        help="replace the --out page, and with the default --out the files generated from "
                             "edp/lib/parameters.toml and edp/lib/formats.toml, each only if this program wrote it (it "
                             "holds the generated mark); without it an existing file is refused")


def command(options) -> int:
    target = Path(options.out)
    pages = {target: page(), **({**parameters.generated(), **formats.generated()} if target.resolve() == PAGE else {})}
    for target in pages:
        claim_file(target, options.force, MARK)
    for target, text in pages.items():
        write_text(target, text)
        print(f"wrote {target}")
    return 0
