# The warning flags every C target of the project builds with (host, sanitizer and cross builds):
# C99, float32 on the DSP (-Wdouble-promotion), no silent conversions.
set(HIL_STRICT_FLAGS -Wall -Wextra -Werror -pedantic -Wconversion -Wdouble-promotion
    -Wfloat-equal -Wshadow -Wstrict-prototypes -Wmissing-prototypes)
