# Portable firmware library (what a user drops into a C2000 project) and the Linux host port.
add_library(hil_fw STATIC
  ${HIL_ROOT}/firmware_stub/src/fw_math.c
  ${HIL_ROOT}/firmware_stub/src/pi_ctrl.c
  ${HIL_ROOT}/firmware_stub/src/svpwm.c
  ${HIL_ROOT}/firmware_stub/src/est_common.c
  ${HIL_ROOT}/firmware_stub/src/est_smo_sign.c
  ${HIL_ROOT}/firmware_stub/src/controller.c
  ${HIL_ROOT}/firmware_stub/src/ctrl_params.c
  ${HIL_ROOT}/firmware_stub/src/hil_session.c
)
target_include_directories(hil_fw PUBLIC ${HIL_ROOT}/firmware_stub/src)
target_compile_options(hil_fw PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(hil_fw PUBLIC hil_protocol m)

add_executable(hil_stub ${HIL_ROOT}/firmware_stub/port/linux/main.c)
target_compile_options(hil_stub PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(hil_stub PRIVATE hil_fw)

# Benchmark helper: raw pty round trip of two C processes (bench/perf/loop.py compares to it).
add_executable(pty_pingpong ${HIL_ROOT}/bench/perf/pty_pingpong.c)
target_compile_options(pty_pingpong PRIVATE -Wall -Wextra -Werror)
target_link_libraries(pty_pingpong PRIVATE util)

add_executable(test_firmware ${HIL_ROOT}/tests/c/test_firmware.c)
target_compile_options(test_firmware PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(test_firmware PRIVATE hil_fw)
add_test(NAME firmware COMMAND test_firmware)
add_test(NAME firmware_no_8bit_types
  COMMAND ${CMAKE_COMMAND} -DHIL_PROTOCOL_DIR=${HIL_ROOT}/firmware_stub/src
          -P ${HIL_ROOT}/protocol/c/check_no_8bit_types.cmake)
