"""The xacro expansion worker: a separate Python process, run by :mod:`kinematics.io.xacro`.

Never imported by the library: ``python -I -B xacro_sandbox.py`` reads one job (JSON on
standard input), expands one xacro document with the ``xacro`` package and writes one JSON
answer on standard output. Before it touches the document it

1. lowers its own limits, hard and soft (they cannot be raised again): CPU time
   (``RLIMIT_CPU``), address space (``RLIMIT_AS``), size of any file written
   (``RLIMIT_FSIZE``: standard output is a file, so this caps the answer), no core files;
2. moves into the job's directory (for an upload, a temporary directory holding nothing but it);
3. imports everything the expansion needs, then patches ``xacro``: documents are parsed with
   ``defusedxml`` (no DTD, no entities), ``$(find pkg)`` resolves only the packages found in
   the job's directories, ``$(env)`` is refused and ``$(optenv)`` gives its default (the
   worker's environment is empty anyway), ``${...}`` expressions are checked on their syntax
   tree (no name, attribute or string with a double underscore or a leading underscore;
   ``python.type`` and ``python.vars`` are gone) and macro calls are counted;
4. installs an audit hook (``sys.addaudithook``; it cannot be removed) that allows only what
   an expansion does: opening a file for reading *inside* the job's directories, listing
   them (glob includes), compiling and evaluating expressions. Any other event -- a file
   outside, a write, a socket, a subprocess, ``os.system``, ``ctypes``, importing a module
   not already loaded -- raises, naming what was refused.

The answer is ``{"ok": true, "urdf": ...}`` or ``{"ok": false, "error": ..., "kind": ...}``
where ``kind`` is ``limit`` for an expansion over one of its limits.
"""

import ast
import errno
import json
import os
import resource
import sys


def _limit(which, value):
    value = int(value)
    resource.setrlimit(which, (value, value))


def _inside(path, roots):
    try:
        real = os.path.realpath(os.fsdecode(path))
    except (TypeError, ValueError):
        return False
    return any(real == r or real.startswith(r + os.sep) for r in roots)


class Refused(PermissionError):
    pass


def main():
    job = json.loads(sys.stdin.buffer.read(1 << 20))
    limits = job["limits"]
    _limit(resource.RLIMIT_CPU, max(1, int(limits["cpu_seconds"] + 0.999)))
    _limit(resource.RLIMIT_AS, limits["memory_bytes"])
    _limit(resource.RLIMIT_FSIZE, limits["output_bytes"] + 65536)
    _limit(resource.RLIMIT_CORE, 0)
    roots = [os.path.realpath(r) for r in job["roots"]]
    packages = {k: os.path.realpath(v) for k, v in job["packages"].items()}
    os.chdir(job["cwd"])

    import xml.dom.minidom  # noqa: F401  (everything the expansion uses, before the hook)
    import xml.parsers.expat
    import glob  # noqa: F401
    import yaml
    import defusedxml.minidom
    from defusedxml import DefusedXmlException
    import xacro
    import xacro.substitution_args as subst
    from xacro import XacroException
    import xacro.cli  # noqa: F401
    import xacro.color  # noqa: F401
    import encodings.idna  # noqa: F401
    yaml.SafeLoader  # noqa: B018

    # -- documents: defusedxml, no DTD or entity of any kind
    def safe_parse(inp, filename=None):
        f = None
        if inp is None:
            try:
                inp = f = open(os.path.join(xacro.root_dir, filename), "rb")
            except OSError as e:
                xacro.filestack.pop()
                raise XacroException((e.strerror or str(e)) + ": " + str(e.filename or filename), exc=e)
        try:
            if isinstance(inp, (str, bytes)):
                return defusedxml.minidom.parseString(inp, forbid_dtd=True)
            if hasattr(inp, "read"):
                return defusedxml.minidom.parse(inp, forbid_dtd=True)
            return inp
        except DefusedXmlException as e:
            raise XacroException(f"{filename or 'the document'} declares a DTD or entities ({type(e).__name__}); "
                                 "they are refused") from None
        finally:
            if f:
                f.close()

    xacro.parse = safe_parse

    # -- $(find pkg), $(env), $(optenv)
    def find(pkg):
        if pkg not in packages:
            known = ", ".join(sorted(packages)[:20]) or "none"
            raise XacroException(f"$(find {pkg}): package {pkg!r} is not in the description (packages: {known})")
        return packages[pkg]

    def env(name):
        raise XacroException(f"$(env {name}) is refused: the expansion sees no environment variables")

    original_abs = xacro.abs_filename_spec

    def abs_filename_spec(spec):
        """``package://pkg/path`` and ``file://path`` in include file names, as ROS tools read them."""
        if isinstance(spec, str) and spec.startswith("package://"):
            pkg, _, rest = spec[len("package://"):].partition("/")
            return os.path.join(find(pkg), rest)
        if isinstance(spec, str) and spec.startswith("file://"):
            spec = spec[len("file://"):]
        return original_abs(spec)

    xacro.abs_filename_spec = abs_filename_spec
    subst._eval_find = find
    subst._eval_env = env
    subst._eval_optenv = lambda name, default="": default
    subst._eval_dict["find"] = find
    subst._eval_dict["env"] = env
    subst._eval_dict["optenv"] = lambda name, default="": default

    # -- ${...}: refuse anything that reaches for Python's internals
    max_expr = int(limits.get("max_expression_chars", 10000))

    def check_expression(expr):
        if len(expr) > max_expr:
            raise XacroException(f"expression of {len(expr)} characters refused (the limit is {max_expr})")
        try:
            tree = ast.parse(expr.strip(), mode="eval")
        except SyntaxError as e:
            raise XacroException(f"invalid expression {expr[:80]!r}: {e.msg}") from None
        for node in ast.walk(tree):
            bad = None
            if isinstance(node, ast.Name) and node.id.startswith("_"):
                bad = node.id
            elif isinstance(node, ast.Attribute) and node.attr.startswith("_"):
                bad = "." + node.attr
            elif isinstance(node, ast.Constant) and isinstance(node.value, (str, bytes)) and (
                    "__" in (node.value if isinstance(node.value, str) else node.value.decode("latin-1"))):
                bad = repr(node.value[:40])
            elif isinstance(node, ast.Attribute) and node.attr in ("format", "format_map"):
                bad = "." + node.attr  # str.format walks attributes: '{0._' '_class_' '_}'
            elif isinstance(node, (ast.Lambda, ast.NamedExpr, ast.Await, ast.Yield, ast.YieldFrom)):
                bad = type(node).__name__.lower()
            if bad is not None:
                raise XacroException(f"expression {expr[:80]!r} refused: it uses {bad} "
                                     "(names and attributes starting with '_' are not allowed)")

    original_eval = xacro.safe_eval

    def strict_eval(expr, globals, locals=None):
        check_expression(expr)
        return original_eval(expr, globals, locals)

    xacro.safe_eval = strict_eval

    def strict_subst_eval(expr, context):
        """``$(eval ...)``: xacro evaluates it with Python's full builtins; here with none."""
        check_expression(expr)
        args = context.setdefault("arg", {})
        functions = {"arg": lambda name: subst.convert_value(subst._eval_arg(name, args=args), "auto"),
                     "dirname": lambda: subst._eval_dirname(context.get("filename"))}
        functions.update(subst._eval_dict)
        functions["__builtins__"] = {}
        return str(eval(expr, {"__builtins__": {}}, subst._DictWrapper(args, functions)))

    subst._eval = strict_subst_eval
    python_ns = xacro._global_symbols.get("python")
    if python_ns is not None:
        for name in ("type", "vars"):
            dict.pop(python_ns, name, None)

    # -- macro calls: an expansion bomb is refused early, by count
    max_calls = int(limits["max_macro_calls"])
    calls = [0]
    original_call = xacro.handle_macro_call

    class TooManyCalls(Exception):
        pass

    def counted_call(node, macros, symbols):
        if node.tagName.startswith("xacro:") and node.tagName not in ("xacro:call",):
            calls[0] += 1
            if calls[0] > max_calls:
                raise TooManyCalls(f"the expansion made more than {max_calls} macro calls (an expansion bomb?)")
        return original_call(node, macros, symbols)

    xacro.handle_macro_call = counted_call

    # -- the audit hook: only reading inside the roots, listing them, compiling expressions
    allowed_modules = set(sys.modules)
    write_flags = os.O_WRONLY | os.O_RDWR | os.O_CREAT | os.O_APPEND | os.O_TRUNC

    def hook(event, args):
        if event == "open":
            path, mode, flags = (list(args) + [None, None, None])[:3]
            if isinstance(path, int):
                raise Refused(errno.EACCES, "opening a file descriptor is not allowed", str(path))
            writing = (isinstance(mode, str) and any(c in mode for c in "wax+")) or (
                isinstance(flags, int) and flags & write_flags)
            if writing:
                raise Refused(errno.EACCES, "writing files is not allowed", os.fsdecode(path))
            if not _inside(path, roots):
                raise Refused(errno.EACCES, "reading outside the description is not allowed", os.fsdecode(path))
            return
        if event in ("os.listdir", "os.scandir", "glob.glob", "glob.glob/2"):
            path = args[0] if args else "."
            if path in (None, ""):
                path = "."
            if not _inside(path if not isinstance(path, int) else ".", roots):
                raise Refused(errno.EACCES, "listing outside the description is not allowed", str(path))
            return
        if event in ("compile", "exec", "sys._getframe", "object.__getattr__"):
            if event == "object.__getattr__":
                raise Refused(errno.EACCES, f"access to {args[1] if len(args) > 1 else 'an attribute'} is not allowed")
            return
        if event == "import":
            if args and args[0] in allowed_modules:
                return
            raise Refused(errno.EACCES, f"importing {args[0] if args else 'a module'} is not allowed")
        if event in ("os.chdir", "os.putenv", "os.unsetenv"):
            raise Refused(errno.EACCES, f"{event} is not allowed")
        if event.startswith(("socket.", "subprocess.", "os.", "ctypes.", "shutil.", "urllib.", "http.",
                             "ftplib.", "smtplib.", "webbrowser", "pty.", "fcntl.", "mmap.", "winreg.",
                             "sys.", "code.", "function.", "cpython.", "marshal.", "pickle.", "shelve.",
                             "sqlite3.", "tempfile.", "resource.", "signal.", "syslog.", "time.", "gc.")):
            raise Refused(errno.EACCES, f"{event} is not allowed during a xacro expansion")

    out = sys.stdout
    entry = job["entry"]
    xacro.verbosity = 0
    sys.stderr = open(os.devnull, "w")  # xacro's warnings; opened before the hook
    sys.addaudithook(hook)
    try:
        doc = xacro.process_file(entry, mappings=dict(job["args"]))
        text = doc.documentElement.toxml()
        if len(text.encode("utf-8")) > limits["output_bytes"]:
            answer = {"ok": False, "kind": "limit",
                      "error": f"the expanded URDF is over {limits['output_bytes']} bytes"}
        else:
            answer = {"ok": True, "urdf": text}
    except TooManyCalls as e:
        answer = {"ok": False, "kind": "limit", "error": str(e)}
    except MemoryError:
        answer = {"ok": False, "kind": "limit",
                  "error": f"the expansion ran out of its memory limit ({limits['memory_bytes'] // (1 << 20)} MiB)"}
    except RecursionError:
        answer = {"ok": False, "kind": "limit", "error": "the expansion recursed too deeply (recursive macros?)"}
    except XacroException as e:
        cause = e
        while isinstance(getattr(cause, "exc", None), BaseException):
            cause = cause.exc
        kind = "limit" if isinstance(cause, (MemoryError, RecursionError, TooManyCalls)) else "error"
        if isinstance(cause, RecursionError):
            msg = "the expansion recursed too deeply (recursive macros?)"
        elif isinstance(cause, MemoryError):
            msg = f"the expansion ran out of its memory limit ({limits['memory_bytes'] // (1 << 20)} MiB)"
        elif isinstance(cause, TooManyCalls):
            msg = str(cause)
        else:
            msg = _message(e)
        answer = {"ok": False, "kind": kind, "error": msg, "file": _where(xacro)}
    except xml.parsers.expat.ExpatError as e:
        answer = {"ok": False, "kind": "error", "error": f"XML parsing error: {e}", "file": _where(xacro)}
    except Refused as e:
        answer = {"ok": False, "kind": "error", "error": f"{e.strerror}: {e.filename}", "file": _where(xacro)}
    except Exception as e:  # noqa: BLE001 - anything else is reported, never a traceback
        answer = {"ok": False, "kind": "error", "error": f"{type(e).__name__}: {e}", "file": _where(xacro)}
    try:
        out.write(json.dumps(answer))
    except MemoryError:
        out.write('{"ok": false, "kind": "limit", "error": "the expansion ran out of memory"}')
    out.flush()


def _message(exc):
    """xacro's message, without the class names it inserts, repeated parts, or 40 lines of context."""
    import re

    text = re.sub(r"<class '[\w.]+'>: ", "", str(exc) or repr(exc))
    text = re.sub(r"(.+?): (\S+) \[Errno \d+\] \1: '\2'", r"\1: \2", text)
    text = re.sub(r"\[Errno \d+\] ", "", text)
    lines = []
    for line in text.split("\n"):
        line = line.strip()
        m = re.fullmatch(r"(.+?) \1", line)
        if m:
            line = m.group(1)
        if line and (not lines or lines[-1] != line):
            lines.append(line)
    if len(lines) > 4:
        lines = lines[:3] + ["..."] + lines[-1:]
    return "; ".join(lines)


def _where(xacro):
    stack = getattr(xacro, "filestack", None) or []
    return str(stack[-1]) if stack and stack[-1] else None


if __name__ == "__main__":
    main()
