"""The ``pinid`` command: one thin module per subcommand (parse → call one public function → print)."""

from pinid.cli.main import build_parser, main

__all__ = ["build_parser", "main"]
