"""Print the README's "Configuration" table from ReconSettings and AgentSettings (Markdown).

Run: .venv/bin/python scripts/settings_table.py
"""

from __future__ import annotations

import sys
from pathlib import Path

from pydantic import AliasChoices
from pydantic.fields import FieldInfo

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from shared.wire.settings import AgentSettings, ReconSettings  # noqa: E402


def env_names(name: str, field: FieldInfo) -> str:
    alias = field.validation_alias
    if isinstance(alias, AliasChoices):
        first, *others = (str(choice) for choice in alias.choices)
        return f"`{first}`" + "".join(f" (or `{other}`)" for other in others)
    return f"`PYSPATIAL_{name.upper()}`"


def shown_default(field: FieldInfo) -> str:
    value = field.default
    if value is None:
        return "unset"
    if isinstance(value, Path):
        home = Path.home()
        return f"`~/{value.relative_to(home)}`" if value.is_relative_to(home) else f"`{value}`"
    if isinstance(value, int) and not isinstance(value, bool) and value >= 2**20 and value % 2**20 == 0:
        return f"`{value}` ({value // 2**20} MiB)"
    return f"`{value}`"


def table() -> str:
    rows = ["| service | variable | default | meaning |", "| --- | --- | --- | --- |"]
    for service, settings in (("recon", ReconSettings), ("agent", AgentSettings)):
        for name, field in settings.model_fields.items():
            rows.append(
                f"| {service} | {env_names(name, field)} | {shown_default(field)} | {field.description} |"
            )
    return "\n".join(rows)


if __name__ == "__main__":
    print(table())
