"""The command line of the build, ``python build_fmu.py``: which FMUs, where, and the system file.

    python build_fmu.py [--dest dist] [--fmu all|IceImpact|ModalStructure|IceImpact3|...]
                        [--standalone] [--variables-table]

Every FMU built is checked with FMPy's validator; with ``--fmu all`` (the default) the system
file of the two FMI 2.0 FMUs, ``IceOnStructure.ssp``, is written beside them.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .fmi2 import build, build_modal
from .fmi3 import FMI3_MODELS, build_fmi3
from .layout import DIST, MODAL_SLAVE_NAME, SLAVE_NAME
from .native import python_version
from .standalone import STANDALONE_DIR, make_standalone

#: What ``--help`` says the command does.
DESCRIPTION = ("Build dist/IceImpact.fmu and dist/ModalStructure.fmu (FMI 2.0 Co-Simulation) "
               "with PythonFMU, and IceImpact3.fmu and ModalStructure3.fmu (FMI 3.0).")

#: The coupled system of examples/system/ (IceImpact.fmu on ModalStructure.fmu), written beside the
#: FMUs when both are built: one file that FMPy, ECOS, libcosim and OMSimulator load as it is
#: (docs/how-to/couple-to-a-structure.md, "The system file in five masters").
SYSTEM_FILE = "IceOnStructure.ssp"


def write_system(dest: str | Path) -> Path:
    """Write ``<dest>/IceOnStructure.ssp`` from the two FMUs built in ``dest``."""
    from iceimpact.fmi.ssp import write_ssp

    return write_ssp(Path(dest), Path(dest) / SYSTEM_FILE)


def _with_standalone(builder, name: str):
    """A builder of BUILDERS: ``(dest, standalone_dest=None) -> FMU``."""
    def build_it(dest: str | Path, standalone_dest: str | Path | None = None) -> Path:
        fmu = builder(dest)
        if standalone_dest is not None:
            make_standalone(fmu, Path(standalone_dest), name)
        return fmu
    return build_it


def _fmi3_builder(model: str):
    """A builder of BUILDERS for ``<model>3.fmu``: from ``<model>.fmu`` (and its standalone
    variant) in the same folders if there, else from an FMI 2.0 build of its own."""
    def build_it(dest: str | Path, standalone_dest: str | Path | None = None) -> Path:
        fmu = Path(dest) / f"{model}.fmu"
        standalone = None if standalone_dest is None else Path(standalone_dest) / fmu.name
        if not fmu.exists() or (standalone is not None and not standalone.exists()):
            fmu = standalone = None
        return build_fmi3(model, dest, standalone_dest, fmu=fmu, standalone=standalone)
    return build_it


#: What ``python build_fmu.py --fmu NAME`` builds: NAME -> ``(dest, standalone_dest) -> FMU``,
#: in this order (the FMI 3.0 FMUs from the FMI 2.0 ones built just before).
BUILDERS = {
    SLAVE_NAME: _with_standalone(build, SLAVE_NAME),
    MODAL_SLAVE_NAME: _with_standalone(build_modal, MODAL_SLAVE_NAME),
    **{identifier: _fmi3_builder(model) for model, (identifier, _) in FMI3_MODELS.items()},
}


def variables_table(fmu: str | Path) -> str:
    """The variables of a built FMU as the contract's Markdown table (the documentation's page
    of FMU variables, docs/reference/fmu-variables.md, is made from the same table)."""
    from fmpy import read_model_description

    from iceimpact.contract import markdown_table

    names = [v.name for v in read_model_description(str(fmu)).modelVariables]
    table = markdown_table()
    missing = [n for n in names if f"| `{n}` |" not in table]
    if missing:
        raise ValueError(f"variables of the FMU missing from the contract: {missing}")
    return table


def main(argv: list[str] | None = None) -> int:
    """Build what the command line ``argv`` asks for; 1 if FMPy's validator found a problem in
    an FMU built, else 0."""
    parser = argparse.ArgumentParser(description=DESCRIPTION)
    parser.add_argument("--dest", default=str(DIST),
                        help="output folder (default: dist)")
    parser.add_argument("--fmu", choices=["all", *BUILDERS], default="all",
                        help="which FMU to build (default: all, i.e. IceImpact.fmu, "
                             "ModalStructure.fmu, IceImpact3.fmu and ModalStructure3.fmu)")
    parser.add_argument("--standalone", action="store_true",
                        help="also write <dest>/standalone/<FMU>.fmu, each with its own CPython "
                             "runtime, numpy and scipy, for Linux x86_64 machines without Python")
    parser.add_argument("--variables-table", action="store_true",
                        help="also print the variables of IceImpact.fmu as a Markdown table "
                             "(the contract's table, as the documentation shows it)")
    args = parser.parse_args(argv)
    from fmpy.validation import validate_fmu

    failed = 0
    for name, builder in BUILDERS.items():
        if args.fmu not in ("all", name):
            continue
        standalone_dest = Path(args.dest) / STANDALONE_DIR if args.standalone else None
        fmu = builder(args.dest, standalone_dest)
        if args.variables_table and name == SLAVE_NAME:
            print(variables_table(fmu))
        problems = validate_fmu(str(fmu))
        for problem in problems:
            print(f"validation: {problem}", file=sys.stderr)
        print(f"built {fmu}" + ("" if not problems else f" ({len(problems)} validation "
                                                       "problems)"))
        failed += bool(problems)
        if standalone_dest is not None:
            standalone = standalone_dest / fmu.name
            print(f"built {standalone} ({standalone.stat().st_size / 1e6:.0f} MB, with its own "
                  f"Python {python_version()}, numpy and scipy)")
    if args.fmu == "all":
        print(f"built {write_system(args.dest)}")
    return 1 if failed else 0
