# The C2000 (TMS320F28335) port skeleton, compiled on the host against the mock of TI's register
# headers (mock/DSP2833x_Device.h, which poisons uint8_t/int8_t: the C28x has no 8-bit type) with
# the project's strict flags, and tested (tests/c/test_c2000_port.c, tests/test_c2000_port.py).
# Included by the top-level CMakeLists.txt. main.c is TI's compiler's only.
set(HIL_C2000_PORT ${HIL_ROOT}/firmware_stub/port/c2000)
add_executable(test_c2000_port ${HIL_ROOT}/tests/c/test_c2000_port.c
               ${HIL_C2000_PORT}/c2000_port.c ${HIL_C2000_PORT}/mock/mock_regs.c)
target_include_directories(test_c2000_port PRIVATE ${HIL_C2000_PORT} ${HIL_C2000_PORT}/mock)
target_compile_options(test_c2000_port PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(test_c2000_port PRIVATE hil_fw)
add_test(NAME c2000_port COMMAND test_c2000_port)
