"""Parameters declared once: name, default, range, unit, help and command-line form.

A scene's :class:`Params` is a frozen dataclass whose fields are declared with :func:`param` (the
frame settings are declared as :class:`Param` too, ``frame/settings.py``).
From that one declaration come the command line's options and their help (with the true
defaults), the checks (kind, count and range, each failing in one line that names the option and
the allowed values), the values a run file holds (``run.py``), the sliders of the WebGL page and
the plan's description. A field declared with ``option=False`` is a parameter of the scene that
the command line does not offer (a test's or the report's knob).

Numbers are floats unless ``integer``; a value of several numbers (``count``) is written
``X,Y,Z`` on the command line and in a run file is a list; one range applies to every component,
or one range per component. ``choices`` lists a word's allowed values; ``flag`` is an on/off
switch; ``text`` is free text the scene parses itself (a shape, a list of emitters).
"""

import argparse
from dataclasses import dataclass, field, fields, replace

from .errors import ParameterError, check_range


@dataclass(frozen=True)
class Param:
    """How one parameter is declared (see the module's docstring)."""

    default: object
    lo: object = None
    hi: object = None
    unit: str = ""
    help: str = ""
    count: object = None  # None: one number; k (or a tuple of allowed k): that many
    integer: bool = False
    choices: tuple = None
    flag: bool = False
    text: bool = False
    optional: bool = False  # None is a value (off)
    option: bool = True  # offered on the command line
    slider: tuple = None  # (uniform, component, lo, hi): a slider of the WebGL page
    metavar: str = None
    name: str = ""

    @property
    def flag_name(self):
        return "--" + self.name.replace("_", "-")

    def convert(self, value, where=None):
        """``value`` checked and in its canonical form (float, int, tuple of floats, word, bool,
        text); ``where`` names it in an error (default its option)."""
        where = where or self.flag_name
        if value is None and (self.optional or self.default is None):
            return None
        if self.flag:
            if not isinstance(value, bool):
                raise ParameterError(f"{where} must be true or false, got {value!r}")
            return value
        if self.text:
            if isinstance(value, int) and not isinstance(value, bool):
                value = str(value)  # a number where text is parsed (--sort 7)
            if not isinstance(value, str):
                raise ParameterError(f"{where} must be text, got {value!r}")
            return value
        if self.choices is not None:
            if value not in self.choices:
                raise ParameterError(f"{where} must be one of {', '.join(map(str, self.choices))}"
                                     f", got {value!r}")
            return value
        if isinstance(value, str):
            value = _numbers(value, where)
        if self.count is None:
            if isinstance(value, (tuple, list)):
                if len(value) != 1:
                    raise ParameterError(f"{where} must be one number, got {value!r}")
                value = value[0]
            return self._number(value, 0, where)
        counts = self.count if isinstance(self.count, tuple) else (self.count,)
        values = tuple(value) if isinstance(value, (tuple, list)) else (value,)
        if len(values) not in counts:
            raise ParameterError(f"{where} must be {' or '.join(map(str, counts))} numbers "
                                 f"separated by commas, got {_text(value)}")
        return tuple(self._number(v, k, where) for k, v in enumerate(values))

    def from_file(self, value, where):
        """``value`` as a run file holds it (a TOML number, list, string or boolean), checked:
        numbers are numbers there, not text to parse as the command line's are."""
        numeric = not (self.flag or self.text or self.choices is not None)
        values = value if isinstance(value, list) else [value]
        if numeric and not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                               for v in values):
            kind = "a number" if self.count is None else "a list of numbers"
            raise ParameterError(f"{where} must be {kind}, got {value!r}")
        counts = self.count if isinstance(self.count, tuple) else (self.count,)
        if numeric and self.count is not None and len(values) not in counts:
            raise ParameterError(f"{where} must be a list of {' or '.join(map(str, counts))} "
                                 f"numbers, got {value!r}")
        return self.convert(value, where)

    def _number(self, value, component, where):
        if self.count is not None and self.count != 1:  # name the component: --noise FREQ
            names = (self.metavar or "X,Y,Z,W").split(",")
            if component < len(names) and names[component].isidentifier():
                where = f"{where} {names[component]}"
            else:
                where = f"{where} component {component + 1}"
        lo = self.lo[component] if isinstance(self.lo, tuple) else self.lo
        hi = self.hi[component] if isinstance(self.hi, tuple) else self.hi
        number = check_range(where, value, lo, hi, integer=self.integer)
        return int(number) if self.integer else float(number)

    def describe_value(self, value):
        """A value as the command line writes it."""
        if value is None:
            return "none"
        if isinstance(value, bool):
            return "on" if value else "off"
        if isinstance(value, tuple):
            return ",".join(_number_text(v) for v in value)
        if isinstance(value, float):
            return _number_text(value)
        return str(value)

    def help_text(self, default_text=None):
        """The option's help: what it is, its unit, range and true default (``default_text``:
        how to state it, where another than the declaration's applies)."""
        words = [self.help.rstrip(".")]
        if self.unit:
            words.append(self.unit)
        if self.choices is not None:
            words.append("one of " + ", ".join(map(str, self.choices)))
        elif self.lo is not None or self.hi is not None:
            words.append(f"in [{_bound(self.lo, '-inf')}, {_bound(self.hi, 'inf')}]")
        if not self.flag:
            words.append(f"default {default_text or self.describe_value(self.default)}")
        return "; ".join(w for w in words if w)


def _bound(value, none):
    if value is None:
        return none
    if isinstance(value, tuple):
        return "(" + ", ".join(_number_text(v) for v in value) + ")"
    return _number_text(value)


def _number_text(value):
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value)) if abs(value) >= 1 or value == 0 else f"{value:g}"
    return f"{value:g}" if isinstance(value, float) else str(value)


def _text(value):
    return ",".join(map(str, value)) if isinstance(value, (tuple, list)) else repr(value)


def _numbers(text, where):
    """The numbers of a comma-separated command-line value."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise ParameterError(f"{where} must be numbers separated by commas, got {text!r}") \
            from None
    return values[0] if len(values) == 1 else values


def param(default, lo=None, hi=None, unit="", help="", **kwargs):
    """A dataclass field declaring a parameter of a scene's :class:`Params`."""
    declared = Param(default, lo, hi, unit, help, **kwargs)
    if isinstance(default, (list, dict)):
        raise TypeError("a parameter's default must be immutable (a tuple, not a list)")
    return field(default=default, metadata={"param": declared})


@dataclass(frozen=True)
class Params:
    """Base of a scene's parameters: each field declared with :func:`param` is checked and put in
    its canonical form when the object is made; :meth:`check` adds the checks between fields."""

    def __post_init__(self):
        for name, declared in self.declarations().items():
            object.__setattr__(self, name, declared.convert(getattr(self, name),
                                                            _where(declared)))
        self.check()

    def check(self):
        """Checks between parameters (a subclass's); raise ParameterError."""

    @classmethod
    def declarations(cls):
        """name -> :class:`Param`, in declaration order."""
        out = {}
        for f in fields(cls):
            if "param" in f.metadata:
                out[f.name] = replace(f.metadata["param"], name=f.name)
        return out

    @classmethod
    def options(cls):
        """The declarations offered on the command line."""
        return {n: d for n, d in cls.declarations().items() if d.option}

    @classmethod
    def add_arguments(cls, parser):
        """Add an option per parameter offered, each defaulting to None (not given) with its
        true default in its help."""
        for name, d in cls.options().items():
            if d.flag:
                parser.add_argument(d.flag_name, dest=name, action="store_true", default=None,
                                    help=d.help_text())
                continue
            metavar = d.metavar or (("N" if d.integer else "X") if d.count is None else ",".join(
                "XYZW"[k] for k in range(d.count if isinstance(d.count, int) else d.count[-1])))
            if d.choices is not None:
                metavar = "{" + ",".join(map(str, d.choices)) + "}"
            if d.text:
                metavar = d.metavar or "TEXT"
            parser.add_argument(d.flag_name, dest=name, default=None, metavar=metavar,
                                help=d.help_text().replace("%", "%%"))

    @classmethod
    def given_in(cls, namespace):
        """name -> value of the parameters given in a parsed command line (None: not given)."""
        values = vars(namespace) if isinstance(namespace, argparse.Namespace) else namespace
        return {name: values[name] for name in cls.options()
                if values.get(name) is not None}

    @classmethod
    def from_mapping(cls, mapping, where="parameters"):
        """The parameters of ``mapping`` (name -> value; the rest default): an unknown name is
        an error naming it and the known ones."""
        known = cls.declarations()
        unknown = [k for k in mapping if k not in known]
        if unknown:
            raise ParameterError(f"{where}: unknown parameter {unknown[0]!r} (known: "
                                 f"{', '.join(known)})")
        return cls(**dict(mapping))

    def values(self):
        """name -> value of every parameter, in declaration order."""
        return {name: getattr(self, name) for name in self.declarations()}

    def changed(self, **changes):
        return replace(self, **changes)

    def describe(self):
        """One line: every offered parameter with its value and unit."""
        words = []
        for name, d in self.options().items():
            value = d.describe_value(getattr(self, name))
            words.append(f"{name} {value}" + (f" {d.unit}" if d.unit and value != "none" else ""))
        return ", ".join(words)


def _where(declared):
    return declared.flag_name if declared.option else declared.name
