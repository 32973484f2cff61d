"""Write the README's table of the bake settings from their one declaration
(native/settings.py), between its markers, so that the guide cannot drift from the code:
`python tools/readme_settings.py`. tests/test_readme.py checks that the table is today's."""
from pathlib import Path
import sys

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from native.settings import EXPOSED_SETTINGS, SETTING_PAIRS  # noqa: E402

README = ROOT / "README.md"
BEGIN, END = "<!-- settings table: begin -->", "<!-- settings table: end -->"
# What an option's value is called in the table, as --help's placeholders.
PLACEHOLDERS = {int: "N", float: "X", str: "NAME"}


def option_of(setting):
    """The command line that sets it: a value's option with its placeholder, a switch with its
    --no- form, or the option of the pair it belongs to."""
    option = setting.exposed.option
    if option is None:
        pair = next(pair for pair in SETTING_PAIRS if setting.name in (pair.lower, pair.upper))
        return f"`{pair.option} MIN MAX`"
    if setting.kind is bool:
        return f"`--[no-]{option[2:]}`"
    return f"`{option} {PLACEHOLDERS[setting.kind]}`"


def number(setting, value):
    """A value as the guide writes it: whole numbers with thousands separators."""
    return f"{value:,}" if setting.kind is int else f"{value:g}"


def default_of(setting):
    """The default as the panel shows it: on or off, a choice's label, a number with its unit,
    or 0 that asks the solver to choose."""
    default = setting.default
    if setting.kind is bool:
        return "on" if default else "off"
    if setting.choices:
        return next(choice.label for choice in setting.choices if choice.identifier == default)
    if default == setting.automatic:
        return f"{number(setting, default)} (automatic)"
    return f"{number(setting, default)} {setting.unit}".strip()


def range_of(setting):
    """The values it takes besides the automatic one: a choice's names, or its bounds."""
    if setting.kind is bool:
        return "on, off"
    if setting.choices:
        return ", ".join(f"`{identifier}`" for identifier in setting.identifiers)
    low, high = setting.minimum, setting.maximum
    if low is not None and high is not None:
        return f"{number(setting, low)} to {number(setting, high)}"
    if low is not None:
        return f"{number(setting, low)} or more"
    return "any" if high is None else f"up to {number(setting, high)}"


def settings_table():
    """The Markdown table of the settings the panel and the command line offer."""
    rows = ["| Setting | Option | Default | Range | What it trades |",
            "| --- | --- | --- | --- | --- |"]
    rows += [f"| {setting.exposed.label} | {option_of(setting)} | {default_of(setting)} | "
             f"{range_of(setting)} | {setting.exposed.trades} |"
             for setting in EXPOSED_SETTINGS]
    return "\n".join(rows)


def readme_table(text=None):
    """The table between the README's markers."""
    text = README.read_text() if text is None else text
    return text[text.index(BEGIN) + len(BEGIN):text.index(END)].strip()


def main():
    text = README.read_text()
    README.write_text(text[:text.index(BEGIN) + len(BEGIN)] + "\n" + settings_table() + "\n"
                      + text[text.index(END):])
    print(settings_table())


if __name__ == "__main__":
    main()
