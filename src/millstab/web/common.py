"""Small pieces the tabs share: a field with its error line, HTML escaping, tables as HTML."""

from __future__ import annotations

import html

import panel as pn

CSS = """
.ms-error { color: #b00020; font-size: 0.9em; }
.ms-done { color: #1b5e20; }
.ms-note { color: #555; font-size: 0.9em; }
.ms-warn { color: #8a4b00; font-size: 0.9em; }
.ms-for { color: #0d47a1; font-size: 0.9em; }
table.ms-table { border-collapse: collapse; font-size: 0.9em; }
table.ms-table td, table.ms-table th { border: 1px solid #ccc; padding: 2px 8px; text-align: right; }
"""


def esc(s: object) -> str:
    return html.escape(str(s))


class Field:
    """A text input holding a value as written in a TOML config (``"903 Hz"``), with an error line beside it."""

    def __init__(self, label: str, value: str, key: str, width: int = 130):
        self.key = key  # the config field name the validators use in their messages
        self.input = pn.widgets.TextInput(label=label, value=value, width=width,
                                          css_classes=["ms-field", f"f-{css_name(key)}"])
        self.error = pn.pane.HTML("", css_classes=["ms-fielderror", f"e-{css_name(key)}"], width=width + 40,
                                  margin=(0, 5))

    def view(self):
        return pn.Column(self.input, self.error, margin=0)

    @property
    def value(self):
        return toml_value(self.input.value)


def css_name(key: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in key)


def toml_value(text: str):
    """A form's text as a TOML value: an integer or a number when it reads as one (TOML's plain numbers),
    else the string (a quantity with units); the validators judge it either way."""
    t = text.strip()
    for kind in (int, float):
        try:
            return kind(t)
        except ValueError:
            pass
    return t


def as_text(value) -> str:
    """A TOML value as the form shows it."""
    return str(value) if not isinstance(value, float) else f"{value:.15g}"


def form_value(widget, name: str, check, empty: str | None = None):
    """A number field's value checked on the server (``check(value)`` raising InputError), or the InputError's text.

    Returns (value, None) or (None, error text). ``empty``: what an empty field must be (an error naming it), or
    None when empty is allowed (the value is then None). Why: a field with browser-side bounds (start/end) kept
    showing what was typed outside them while the server kept the last value inside, and the job ran with that
    (an exploratory test: 50 samples shown, 1 000 run; an a/D of 1.5 shown, the previous one decided for)."""
    from millstab.errors import InputError

    value = widget.value
    try:
        if value is None:
            if empty is None:
                return None, None
            raise InputError(name, "empty", empty)
        return check(value), None
    except InputError as exc:
        return None, str(exc)


def error_html(text: str) -> str:
    return f'<span class="ms-error">{esc(text)}</span>' if text else ""


def computed_for(origin: str) -> str:
    """The line over a result that says which structure it is for (the session's ``origin`` when the work
    started): a posterior of the packaged example must not pass for one of the user's tool."""
    return f'<div class="ms-for"><b>computed for:</b> {esc(origin)}</div>' if origin else ""


def html_table(header, rows, css: str = "") -> str:
    head = "".join(f"<th>{esc(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f'<table class="ms-table {css}"><tr>{head}</tr>{body}</table>'


class TextBox:
    """HTML the page rewrites often (summaries, status lines, result tables): a Bokeh ``Div`` whose
    ``text`` changes without re-walking the document's models, as a Panel HTML pane's update does
    (≈ 0.3 s of the server's thread on this page, under load)."""

    def __init__(self, css: str, width: int | None = 1000, height: int | None = 44):
        from bokeh.models import Div

        # a fixed size: a new text does not re-lay the page out in the browser either
        size = {k: v for k, v in (("width", width), ("height", height)) if v is not None}
        self.div = Div(text="", css_classes=[css], stylesheets=[CSS], **size)

    @property
    def text(self) -> str:
        return self.div.text

    @text.setter
    def text(self, html: str) -> None:
        import panel as pn

        if html != self.div.text:
            with pn.io.unlocked():
                self.div.text = html

    def view(self):
        import panel as pn

        return pn.pane.Bokeh(self.div)
