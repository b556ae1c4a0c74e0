"""Options declared once: a dataclass field with an ``Option`` says everything the command
line, the bake operator, the panel and the Dask workers need to offer and check it.

``option(default, ...)`` declares a field; ``add_arguments`` turns fields into argparse
options, ``operator_properties`` into bpy properties, ``check`` validates an instance and
``to_argv`` writes an instance back as command-line words (for the Dask workers).  No bpy
here: ``operator_properties`` takes the ``bpy.props`` module as an argument.
"""

import argparse
import math
import os
from collections.abc import Callable
from dataclasses import MISSING, dataclass, field, fields
from typing import Any

from ..core.arguments import real_number


@dataclass(frozen=True)
class Option:
    label: str  #: the panel's and operator's name
    tooltip: str  #: the panel's tooltip and the --help text
    flag: str | None = None  #: on the command line as this flag; None: not there
    low: float | None = None
    high: float | None = None
    low_open: bool = False  #: ``low`` itself is refused: the range is (low, high]
    finite: bool = False  #: NaN and infinities are refused
    whole: bool = False  #: a whole number
    unit: str = ""  #: "degrees", "scene units", "texels": said in messages and --help
    #: The allowed values (an enum in the operator); with a tuple default, the value is some of
    #: them, each once (comma-separated on the command line, a set of toggles in the operator).
    choices: tuple = ()
    #: How front ends take the value: "value", "path" (a folder), "collection" (a collection's name).
    kind: str = "value"
    ui: bool = True  #: a property of the bake operator
    ui_default: Any = None  #: the operator's default, where it differs (e.g. a "//" path)
    #: A number that may be None ("automatic", as the tooltip says): the operator, whose
    #: properties cannot be None, shows None as this value and reads it back as None.
    auto: Any = None
    metavar: str | None = None
    #: Command-line words -> value (argparse ``type``), for values that are not plain numbers or words.
    parse: Callable[[str], Any] | None = None
    #: The value sets how the map is estimated (its noise), not what it is: a map that reads this
    #: one takes it baked with any value.
    estimate: bool = False


def option(default=MISSING, *, default_factory=MISSING, **meta) -> Any:
    """A dataclass field declared as an option (see ``Option`` for ``meta``)."""
    return field(default=default, default_factory=default_factory, metadata={"option": Option(**meta)})


def declared(cls_or_instance: Any) -> list[tuple[str, Option, Any]]:
    """(field name, Option, default) of every option field of a dataclass, in order."""
    found = []
    for item in fields(cls_or_instance):
        if "option" in item.metadata:
            default = item.default_factory() if item.default_factory is not MISSING else item.default
            found.append((item.name, item.metadata["option"], default))
    return found


def is_several(opt: Option, default: Any) -> bool:
    """Whether the option's value is some of its choices (a tuple), not one of them."""
    return bool(opt.choices) and isinstance(default, tuple)


def is_some_of(chosen: tuple, choices: tuple) -> bool:
    """Whether ``chosen`` is one or more of ``choices``, each once."""
    return bool(chosen) and len(set(chosen)) == len(chosen) and not set(chosen) - set(choices)


def comma_words(text: str) -> tuple[str, ...]:
    """The words of a comma-separated text, as the command line gives a list ("a, b,c")."""
    return tuple(word.strip() for word in text.split(",") if word.strip())


def check_value(name: str, opt: Option, value: Any) -> None:
    """ValueError naming the option when ``value`` is outside its declared range."""
    if is_several(opt, value):
        if not is_some_of(value, opt.choices):
            raise ValueError(f"{name} must be some of {', '.join(map(str, opt.choices))}, each once, not {value!r}")
        return
    if opt.choices and value not in opt.choices:
        raise ValueError(f"{name} must be one of {', '.join(map(str, opt.choices))}, not {value!r}")
    if opt.low is None and opt.high is None and not opt.finite and not opt.whole:
        return
    number = real_number(name, value)
    bad = math.isnan(number) or (opt.finite and math.isinf(number)) or (opt.whole and not number.is_integer())
    bad = bad or (opt.low is not None and (number <= opt.low if opt.low_open else number < opt.low))
    bad = bad or (opt.high is not None and number > opt.high)
    if bad:
        raise ValueError(f"{name} must be {describe_range(opt)}, not {value}")


def folder_path(name: str, value: Any) -> str:
    """``value`` as a path string: a str or an ``os.PathLike``; else ValueError naming ``name``."""
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if not isinstance(value, str):
        raise ValueError(f"{name} must be a path (a str or os.PathLike), not {value!r}")
    return value


def several_of(choices: tuple) -> Callable[[str], tuple]:
    """The command line's parser of a comma-separated list of some of ``choices``, each once."""

    def parse(text: str) -> tuple:
        chosen = comma_words(text)
        if not is_some_of(chosen, choices):
            raise argparse.ArgumentTypeError(f"expected some of {', '.join(choices)}, comma-separated, got {text!r}")
        return chosen

    return parse


def describe_range(opt: Option) -> str:
    """'in (0, 89] degrees', 'a whole number of texels from 8 to 16384', 'at least 1', ..."""
    unit = f" {opt.unit}" if opt.unit else ""
    if opt.whole and opt.low is not None and opt.high is not None:
        return f"a whole number{' of ' + opt.unit if opt.unit else ''} from {opt.low:.0f} to {opt.high:.0f}"
    if opt.low is not None and opt.high is not None:
        return f"in {'(' if opt.low_open else '['}{opt.low:g}, {opt.high:g}]{unit}"
    if opt.low == 0 and opt.low_open:
        return f"a positive number{' of ' + opt.unit if opt.unit else ''}"
    if opt.low is not None:
        return f"{'above' if opt.low_open else 'at least'} {opt.low:g}{unit}"
    if opt.high is not None:
        return f"at most {opt.high:g}{unit}"
    return f"a finite number{' of ' + opt.unit if opt.unit else ''}"


def check(instance: Any, prefix: str = "") -> None:
    """Check every option field of a dataclass instance (``__post_init__`` calls it)."""
    for name, opt, _ in declared(instance):
        value = getattr(instance, name)
        if value is not None or (opt.kind == "value" and opt.auto is None):
            check_value(prefix + opt.label.lower(), opt, value)


# --- front ends --------------------------------------------------------------------------------


@dataclass(frozen=True)
class Entry:
    """One option as the front ends see it: ``dest`` names it in argparse's namespace and as an
    operator property; ``name`` is its dataclass field; ``owner`` the map whose settings hold it
    (None: a general bake option)."""

    dest: str
    name: str
    option: Option
    default: Any
    owner: str | None = None


def entries(cls: type, owner: str | None = None) -> list[Entry]:
    """The Entries of a dataclass's option fields: ``dest`` is the field name for general
    options and the flag's words for a map's settings (--rain-cone -> rain_cone)."""
    found = []
    for name, opt, default in declared(cls):
        if owner is None:
            dest = name
        elif opt.flag:
            dest = opt.flag.lstrip("-").replace("-", "_")
        else:
            dest = f"{owner}_{name}"
        found.append(Entry(dest, name, opt, default, owner))
    return found


def add_arguments(parser: argparse.ArgumentParser, items: list[Entry]) -> None:
    """One argparse option per entry that has a flag."""
    for entry in items:
        opt, default = entry.option, entry.default
        if opt.flag is None:
            continue
        number = default if opt.auto is None else opt.auto
        kind = type(number) if isinstance(number, (int, float)) and not isinstance(number, bool) else str
        several = is_several(opt, default)
        if opt.parse is not None or several:
            kind = several_of(opt.choices) if several else opt.parse
            shown = f" (default: {','.join(default)})" if default else ""
        elif isinstance(default, float):
            shown = f" (default: {default:g})"
        else:
            shown = f" (default: {default})" if default is not None else ""
        unit = f", {opt.unit}" if opt.unit and opt.unit != "texels" else ""
        parser.add_argument(
            opt.flag,
            dest=entry.dest,
            default=default,
            type=kind,
            choices=None if several else opt.choices or None,
            metavar=opt.metavar,
            help=f"{opt.tooltip}{unit}{shown}",
        )


def to_argv(items: list[Entry], value_of: Callable[[Entry], Any]) -> list[str]:
    """The command-line words that give the entries' values back (for a subprocess)."""
    words = []
    for entry in items:
        value = value_of(entry)
        if entry.option.flag is None or value is None:
            continue
        if isinstance(value, bool):  # a switch: its flag alone, or nothing
            words += [entry.option.flag] * value
            continue
        if entry.option.kind == "collection":
            value = getattr(value, "name", value)
        elif isinstance(value, (tuple, list)):  # a list of words or numbers, comma-separated
            value = ",".join(item if isinstance(item, str) else repr(item) for item in value)
        words += [entry.option.flag, value if isinstance(value, str) else repr(value)]
    return words


def operator_properties(props: Any, items: list[Entry]) -> dict:
    """{dest: bpy property} for the entries shown in the operator; ``props`` is ``bpy.props``."""
    properties = {}
    for entry in items:
        opt = entry.option
        if not opt.ui:
            continue
        default = next((value for value in (opt.ui_default, entry.default, opt.auto) if value is not None), None)
        common = dict(name=opt.label, description=opt.tooltip + (f" ({opt.unit})" if opt.unit else ""))
        items_ = [(str(choice), str(choice).title(), f"{opt.label}: {choice}") for choice in opt.choices]
        if is_several(opt, default):
            prop = props.EnumProperty(items=items_, options={"ENUM_FLAG"}, default=set(default), **common)
        elif opt.choices:
            prop = props.EnumProperty(items=items_, default=str(default), **common)
        elif isinstance(default, bool):
            prop = props.BoolProperty(default=default, **common)
        elif isinstance(default, int):
            bounds = {key: int(value) for key, value in (("min", opt.low), ("max", opt.high)) if value is not None}
            prop = props.IntProperty(default=default, **bounds, **common)
        elif isinstance(default, float):
            bounds = {key: value for key, value in (("min", opt.low), ("max", opt.high)) if value is not None}
            length = {"subtype": "DISTANCE", "unit": "LENGTH"} if opt.unit == "scene units" else {}
            prop = props.FloatProperty(default=default, **bounds, **length, **common)
        else:
            # a folder may be "//", the .blend's (Blender warns unless the property says so)
            subtype = {"subtype": "DIR_PATH", "options": {"PATH_SUPPORTS_BLEND_RELATIVE"}} if opt.kind == "path" else {}
            prop = props.StringProperty(default=default or "", **subtype, **common)
        properties[entry.dest] = prop
    return properties


def operator_value(opt: Option, value: Any) -> Any:
    """``value`` as read from the operator: its stand-in for None (``opt.auto``) is None again, and
    a set of toggles (some of the choices) the tuple of them in the choices' order."""
    if opt.choices and isinstance(value, set):
        return tuple(choice for choice in opt.choices if choice in value)
    return None if opt.auto is not None and value == opt.auto else value


def argument_values(namespace: argparse.Namespace, items: list[Entry]) -> dict:
    """{field name: value} of the entries, as the parser ``add_arguments`` gave them parsed them
    into ``namespace``: the keywords of their dataclass."""
    return {entry.name: getattr(namespace, entry.dest) for entry in items}


def operator_values(operator: Any, items: list[Entry]) -> dict:
    """{dest: value} of the entries ``operator_properties`` gave ``operator``, each as
    ``operator_value`` reads it."""
    return {
        entry.dest: operator_value(entry.option, getattr(operator, entry.dest)) for entry in items if entry.option.ui
    }
