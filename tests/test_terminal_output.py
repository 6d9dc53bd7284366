"""What the commands print: aligned tables that fit 120 columns (pinid.report.text)."""

from __future__ import annotations

from pinid.report.text import text_table


def _starts(line: str) -> list[int]:
    """Start of every cell (cells are separated by two or more spaces)."""
    import re

    return [m.start() for m in re.finditer(r"(?:(?<=  )|^)\S", line)]


def test_columns_align_with_long_names():
    """Long joint or model names widen their column instead of pushing the row out of line (pinid track)."""
    rows = [
        ["backstepping", "cad:30", "hip", "14.891"],
        ["computed-torque", "identified_model_of_the_left_leg.json", "left_hip_flexion_extension_joint", "0.035"],
    ]
    text = text_table(["controller", "model", "joint", "RMS [mrad]"], rows, keys=3)
    lines = text.splitlines()
    assert len(lines) == 4 and len({len(line) for line in lines}) == 1  # every line as wide: right edges align
    assert _starts(lines[0])[:3] == _starts(lines[2])[:3] == _starts(lines[3])[:3]


def test_wide_tables_split_to_fit_repeating_the_key_column():
    header = ["method"] + [f"panda_joint{k} |e| [N·m]" for k in range(1, 8)]
    rows = [[m] + ["0.05596 ± 0.1355"] * 7 for m in ("ols", "rls-pso", "ewoa")]
    text = text_table(header, rows, width=120)
    assert max(map(len, text.splitlines())) <= 120
    parts = text.split("\n\n")
    assert len(parts) >= 2
    for part in parts:
        assert part.splitlines()[0].startswith("method") and [line.split()[0] for line in part.splitlines()[2:]] == [
            "ols",
            "rls-pso",
            "ewoa",
        ]
    assert sum(part.splitlines()[0].count("panda_joint") for part in parts) == 7  # every column exactly once
