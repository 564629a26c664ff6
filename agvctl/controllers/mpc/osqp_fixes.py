"""Fixes to OSQP's generated C that make it compile with ``-std=c99 -Wall -Wextra -Werror``.

OSQP's code generation (osqp 1.1.3, embedded mode 2, printing off) writes 17 warnings under those flags: one
``-Wparentheses`` in ``auxil.c``, empty ``if`` bodies and unused parameters in ``error.c`` (``c_print`` expands to
nothing without printing), static functions that only the desktop build uses in ``csc_utils.c`` and ``kkt.c``, and
struct initialisers without their last field in the generated workspace. Each fix here is an exact substitution that
must match as many times as it states; an OSQP whose text differs fails loudly instead of skipping one. None uses a
``#pragma`` or changes what the code computes. The generation time OSQP writes into three files is replaced too, so
the same QP always gives the same files (and the same cached library).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from agvctl.errors import AgvctlError

__all__ = ["OSQP_FIXES", "OSQP_VERSION", "SourceFix"]

OSQP_VERSION = "1.1.3"
"""The OSQP release whose generated text :data:`OSQP_FIXES` is written against (pinned in ``pyproject.toml``)."""


@dataclass(frozen=True)
class SourceFix:
    """One exact substitution in one generated file, and why it is needed.

    Parameters
    ----------
    path : str
        The file, relative to the generated folder; ``{workspace}`` stands for the workspace's stem.
    pattern : str
        A regular expression (:func:`re.escape` of the old text for a literal one).
    replacement : str
        Its replacement (``re.sub`` syntax).
    count : int
        How many times it must match, exactly.
    reason : str
        The warning it removes and why the change keeps OSQP's meaning.
    """

    path: str
    pattern: str
    replacement: str
    count: int
    reason: str

    def apply(self, text: str) -> str:
        """``text`` with the substitution made.

        Parameters
        ----------
        text : str
            The file's text.

        Returns
        -------
        str
            The fixed text.

        Raises
        ------
        AgvctlError
            The pattern does not match exactly :attr:`count` times (the generated text is not the one the fix is
            written for).
        """
        fixed, n = re.subn(self.pattern, self.replacement, text)
        if n != self.count:
            raise AgvctlError(
                f"OSQP's generated {self.path} is not the text the fix expects ({n} matches, not {self.count}): "
                f"{self.reason}; is osqp {OSQP_VERSION} installed?"
            )
        return fixed


_ERROR_BODY = r"""(  /\* Don't print anything if there was no error \*/
)  if \(error_code != OSQP_NO_ERROR\)
    (c_print\("ERROR in %s{where}: %s\\n", function_name{args}, OSQP_ERROR_MESSAGE\[error_code-1\]\);)
"""
_UNUSED = "  (void)function_name; /* agvctl: unused when printing is off */\n"

OSQP_FIXES: tuple[SourceFix, ...] = (
    SourceFix(
        "src/auxil.c",
        re.escape("if (from_setup &&\n      settings->adaptive_rho < 0 ||"),
        "if ((from_setup &&\n      settings->adaptive_rho < 0) ||",
        1,
        "-Wparentheses: && already binds tighter than ||; the parentheses state that reading, the meaning is kept",
    ),
    SourceFix(
        "src/error.c",
        _ERROR_BODY.format(where="", args=""),
        r"\1" + _UNUSED + r"  if (error_code != OSQP_NO_ERROR) {\n    \2\n  }\n",
        1,
        "-Wempty-body and -Wunused-parameter: with printing off c_print expands to nothing; braces and a (void) cast",
    ),
    SourceFix(
        "src/error.c",
        _ERROR_BODY.format(where=r" \(%s:%\" OSQP_INT_FMT \"\)", args=", filename, line_number"),
        r"\1"
        + _UNUSED
        + r"  (void)filename;\n  (void)line_number;\n  if (error_code != OSQP_NO_ERROR) {\n    \2\n  }\n",
        1,
        "-Wempty-body and -Wunused-parameter: as in _osqp_error, for the variant with the file and line",
    ),
    SourceFix(
        "src/csc_utils.c",
        r"(?s)(#endif /\* OSQP_EMBEDDED_MODE \*/\n)\n"
        r"(static void prea_int_vec_copy\(.*?\n}\n\nstatic void prea_vec_copy\(.*?\n}\n)",
        r"\n\2\1",
        1,
        "-Wunused-function: the two copies serve only the desktop build's csc_copy; moved inside its #ifndef",
    ),
    SourceFix(
        "src/csc_utils.c",
        r"(?s)(static void int_vec_set_scalar\(.*?\n}\n)",
        r"#ifndef OSQP_EMBEDDED_MODE /* agvctl: only csc_submatrix_byrows, a desktop function, uses it */\n\1#endif\n",
        1,
        "-Wunused-function: int_vec_set_scalar serves only the desktop build's csc_submatrix_byrows; put in an #ifndef",
    ),
    SourceFix(
        "src/kkt.c",
        r"(?s)(//add an offset to every term in the upper nxn block\.\n.*?\n}\n\n)(#ifndef OSQP_EMBEDDED_MODE\n)",
        r"\2\1",
        1,
        "-Wunused-function: the KKT shifts serve only the desktop build's form_KKT; the #ifndef moved above them",
    ),
    SourceFix(
        "{workspace}.c",
        r"(OSQPCscMatrix \w+ = \{\n(?:  [^\n]*\n){6}  -1,\n)\};",
        r"\1  0,\n};",
        4,
        "-Wmissing-field-initializers: each CSC matrix's 'owned' flag, 0: static data the solver never frees",
    ),
    SourceFix(
        "{workspace}.c",
        r"(  \w+_linsys_fwork,\n)\};",
        r"\1  OSQP_NULL,\n};",
        1,
        "-Wmissing-field-initializers: QDLDL's 'adj', the adjoint-derivative matrix, unused by the embedded solver",
    ),
    SourceFix(
        "{workspace}.c",
        r"This file was autogenerated by OSQP on [^\n]*",
        f"This file was generated by OSQP {OSQP_VERSION}'s code generation",
        1,
        "determinism: the generation time would make every generation a different source",
    ),
    SourceFix(
        "{workspace}.h",
        r"This file was autogenerated by OSQP on [^\n]*",
        f"This file was generated by OSQP {OSQP_VERSION}'s code generation",
        1,
        "determinism: as in the workspace",
    ),
    SourceFix(
        "osqp_configure.h",
        r"This file was autogenerated by OSQP on [^\n]*",
        f"This file was generated by OSQP {OSQP_VERSION}'s code generation",
        1,
        "determinism: as in the workspace",
    ),
)
"""The fixes that make OSQP's generated solver compile with
:data:`~agvctl.controllers.pi.c_loops.STRICT_C_FLAGS`, in the order applied."""
