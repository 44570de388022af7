"""A small document model for the report's texts, rendered to Markdown and to self-contained
HTML (figures embedded)."""

from __future__ import annotations

import base64
import html
from pathlib import Path


class Doc:
    """A tiny document model rendered to Markdown and to self-contained HTML."""

    def __init__(self):
        self.blocks: list[tuple] = []

    def h(self, level: int, text: str):
        self.blocks.append(("h", level, text))

    def p(self, text: str):
        self.blocks.append(("p", text))

    def ul(self, items: list[str]):
        self.blocks.append(("ul", items))

    def table(self, header: list[str], rows: list[list[str]], align: str | None = None):
        self.blocks.append(("table", header, rows, align or "l" + "r" * (len(header) - 1)))

    def fig(self, path: Path, caption: str):
        self.blocks.append(("fig", path, caption))

    def markdown(self) -> str:
        out = []
        for b in self.blocks:
            if b[0] == "h":
                out.append("#" * b[1] + " " + b[2])
            elif b[0] == "p":
                out.append(b[1])
            elif b[0] == "ul":
                out.append("\n".join(f"- {i}" for i in b[1]))
            elif b[0] == "table":
                _, head, rows, al = b
                esc = lambda s: str(s).replace("|", "\\|")  # noqa: E731
                lines = ["| " + " | ".join(esc(c) for c in head) + " |",
                         "|" + "|".join(":---" if a == "l" else "---:" for a in al) + "|"]
                lines += ["| " + " | ".join(esc(c) for c in r) + " |" for r in rows]
                out.append("\n".join(lines))
            elif b[0] == "fig":
                out.append(f"![{b[1].stem.replace('-', ' ')}]({b[1].name})\n\n*{b[2]}*")
        return "\n\n".join(out) + "\n"

    def html(self, title: str) -> str:
        def inline(s: str) -> str:
            # the Markdown subset used in the texts: `code` and **bold**
            t = html.escape(s)
            import re

            t = re.sub(r"`([^`]+)`", r"<code>\1</code>", t)
            t = re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", t)
            return t

        body = []
        for b in self.blocks:
            if b[0] == "h":
                body.append(f"<h{b[1]}>{inline(b[2])}</h{b[1]}>")
            elif b[0] == "p":
                body.append(f"<p>{inline(b[1])}</p>")
            elif b[0] == "ul":
                body.append("<ul>" + "".join(f"<li>{inline(i)}</li>" for i in b[1]) + "</ul>")
            elif b[0] == "table":
                _, head, rows, al = b
                cls = lambda a: ' class="r"' if a == "r" else ""  # noqa: E731
                th = "".join(f"<th{cls(a)}>{inline(c)}</th>" for c, a in zip(head, al))
                t = ["<table><thead><tr>" + th + "</tr></thead><tbody>"]
                t += ["<tr>" + "".join(f"<td{cls(a)}>{inline(c)}</td>" for c, a in zip(r, al))
                      + "</tr>" for r in rows]
                body.append("".join(t) + "</tbody></table>")
            elif b[0] == "fig":
                data = base64.b64encode(b[1].read_bytes()).decode("ascii")
                body.append(f'<figure><img alt="{html.escape(b[1].name)}" '
                            f'src="data:image/png;base64,{data}">'
                            f"<figcaption>{inline(b[2])}</figcaption></figure>")
        style = ("body{font-family:system-ui,-apple-system,Segoe "
                 "UI,Roboto,sans-serif;max-width:1100px;"
                 "margin:2em auto;padding:0 1em;color:#222;line-height:1.45}"
                 "table{border-collapse:collapse;margin:0.8em 0}th,td{border:1px solid "
                 "#ccc;padding:3px 8px}"
                 "th{background:#f3f3f3}td.r,th.r{text-align:right}img{max-width:100%;height:auto}"
                 "figure{margin:1em "
                 "0}figcaption{color:#555;font-size:0.9em}code{background:#f3f3f3;padding:0 3px}")
        return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta "
                f"charset=\"utf-8\"><title>{html.escape(title)}"
                f"</title><style>{style}</style></head><body>\n" + "\n".join(body)
                + "\n</body></html>\n")
