"""MkDocs hook: the table of the spec's declared fields, generated from their declarations.

``reference/campaign-file.md`` holds the marker ``<!-- spec-fields -->``; this hook replaces it with
one row per declared field of ``ShearCellSpec`` (``calibrax.core.sheartest.fields``): its dotted
path, symbol, unit, allowed range, whether a campaign may calibrate it, and the backend capability a
value other than its "off" value needs. The ranges that validation and the search boxes use are
these, so the page cannot fall out of step with them. The build fails when the page lacks the
marker or calibrax cannot be imported.
"""

from __future__ import annotations

from mkdocs.exceptions import PluginError

PAGE = "reference/campaign-file.md"
MARKER = "<!-- spec-fields -->"


def fields_markdown() -> str:
    """The generated table."""
    try:
        from calibrax.core.sheartest import ShearCellSpec
        from calibrax.core.sheartest.fields import declared_fields
    except ImportError as exc:
        raise PluginError(f"spec_fields hook: cannot import calibrax ({exc}); build the docs from the project's "
                          ".venv (make setup)") from exc
    rows = ["| field | symbol | unit | allowed | calibratable | a value other than `off` needs |",
            "|---|---|---|---|---|---|"]
    for path, info in declared_fields(ShearCellSpec):
        if info.numeric:
            allowed = ("an integer " if info.integer else "") + info.interval() + (", or `null`" if info.optional else "")
        else:
            allowed = "see the field"
        needs = f"`{info.capability}` (off: `{info.off!r}`)" if info.capability else ""
        shown = f"{info.symbol}, in {info.display_unit}" if info.display_unit and info.symbol else info.symbol
        rows.append(f"| `{path}` | {shown} | {info.unit or '–'} | {allowed} | "
                    f"{'yes' if info.calibratable else ''} | {needs} |")
    return "\n".join(rows)


def on_page_markdown(markdown: str, page, config, files):
    if page.file.src_uri != PAGE:
        return markdown
    if MARKER not in markdown:
        raise PluginError(f"spec_fields hook: {PAGE} lacks the marker {MARKER} where the table of the spec's "
                          "declared fields goes")
    return markdown.replace(MARKER, fields_markdown())
