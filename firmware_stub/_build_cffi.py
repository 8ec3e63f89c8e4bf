"""cffi API-mode bindings to the portable firmware (estimator library, FOC, session).

Declarations live in ``firmware_stub/cdef/*.cdef`` (one file per C module, cffi syntax; partial
structs end in ``...;`` so the real header fixes the layout). Every ``firmware_stub/src/*.c`` is
compiled in, with the generated protocol codec, exactly as the stub and the DSP build them.
Built by CMake (cmake/cffi_modules.cmake: into the wheel, or by ``make build`` next to this
file) into ``hil_bench.firmware_stub._fw_c``; ``make_builder(sanitize=True)`` is the
AddressSanitizer + UndefinedBehaviorSanitizer build (``make sanitize``, imported from
build-asan/python/).
"""
from pathlib import Path

from cffi import FFI

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
SRC = HERE / "src"
PROTOCOL_C = ROOT / "protocol" / "c"

#: compile and link flags of the sanitized build (tools/build_native.py --sanitize)
SANITIZE_COMPILE_ARGS = ["-O1", "-g", "-std=c99", "-fno-omit-frame-pointer",
                         "-fsanitize=address,undefined", "-fno-sanitize-recover=undefined"]
SANITIZE_LINK_ARGS = ["-fsanitize=address,undefined"]


def make_builder(sanitize: bool = False) -> FFI:
    """The module's builder; ``sanitize``: -fsanitize=address,undefined instead of -O2."""
    builder = FFI()
    # fw_common first: the other declarations use its types; the controller last: it holds the
    # other modules' state structs
    cdefs = sorted(HERE.glob("cdef/*.cdef"),
                   key=lambda p: (p.stem != "fw_common", p.stem == "controller", p.stem))
    builder.cdef("\n".join(p.read_text() for p in cdefs))
    headers = "".join(f'#include "{h.name}"\n' for h in sorted(SRC.glob("*.h")))
    sources = sorted(str(p) for p in SRC.glob("*.c"))
    sources += [str(PROTOCOL_C / "hil_msgs.c"), str(PROTOCOL_C / "hil_framing.c")]
    builder.set_source(
        "hil_bench.firmware_stub._fw_c", headers, sources=sources,
        include_dirs=[str(SRC), str(PROTOCOL_C)],
        extra_compile_args=SANITIZE_COMPILE_ARGS if sanitize else ["-O2", "-std=c99"],
        extra_link_args=SANITIZE_LINK_ARGS if sanitize else [],
        libraries=["m"])
    return builder


ffibuilder = make_builder()

if __name__ == "__main__":
    ffibuilder.compile(verbose=True)
