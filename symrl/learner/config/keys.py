"""The config keys' documentation (``symrl train [RECIPE] --help-keys``): every key, its value
and its description, read from the schema."""

from __future__ import annotations

from typing import Any

from symrl.learner.config.merging import value_at
from symrl.learner.config.schema import RunConfig, config_to_dict


def describe_keys(config: RunConfig | None = None) -> str:
    """Every config key with its value in ``config`` (the library default where a recipe changes
    it is shown beside it) and its description, from the schema: the string under each field
    (for ``symrl train [RECIPE] --help-keys``)."""
    config = config if config is not None else RunConfig()
    schema = RunConfig.model_json_schema()
    defs = schema.get("$defs", {})
    defaults = config_to_dict(RunConfig())
    rows = [
        f"Config keys of recipe {config.recipe!r}: key = value, then what it means. "
        "Override one as key=value."
    ]

    def section(field: dict[str, Any]) -> dict[str, Any] | None:
        ref = field.get("$ref") or next((f["$ref"] for f in field.get("allOf", [])), None)
        return defs[ref.rsplit("/", 1)[-1]] if ref else None

    def walk(prefix: str, properties: dict[str, Any], values: dict[str, Any]) -> None:
        nested = []
        for name, field in properties.items():
            key, inner = f"{prefix}{name}", section(field)
            doc = " ".join((field.get("description") or "").split())
            if inner is not None:  # a section: its keys after the plain ones
                doc = doc or " ".join(inner.get("description", "").split())
                nested.append((key, doc, inner["properties"], values[name]))
                continue
            default = value_at(defaults, key)
            changed = f"  (default {default!r})" if values[name] != default else ""
            rows.append(f"  {key} = {values[name]!r}{changed}")
            if doc:
                rows.append(f"      {doc}")
        for key, doc, inner_properties, inner_values in nested:
            rows.append(f"{key}:" + (f"  {doc}" if doc else ""))
            walk(f"{key}.", inner_properties, inner_values)

    walk(
        "", {k: v for k, v in schema["properties"].items() if k != "recipe"}, config_to_dict(config)
    )
    return "\n".join(rows)
