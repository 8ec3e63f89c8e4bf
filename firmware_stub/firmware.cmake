# Portable firmware library (what a user drops into a C2000 project) and the Linux host port.
# Every firmware_stub/src/*.c is part of the library; every tests/c/test_fw_*.c is a test.
file(GLOB HIL_FW_SOURCES CONFIGURE_DEPENDS ${HIL_ROOT}/firmware_stub/src/*.c)
add_library(hil_fw STATIC ${HIL_FW_SOURCES})
target_include_directories(hil_fw PUBLIC ${HIL_ROOT}/firmware_stub/src)
target_compile_options(hil_fw PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(hil_fw PUBLIC hil_protocol m)

set(HIL_STUB_PORT ${HIL_ROOT}/firmware_stub/port/linux)
add_executable(hil_stub ${HIL_STUB_PORT}/main.c ${HIL_STUB_PORT}/transport.c
               ${HIL_STUB_PORT}/transport_serial.c ${HIL_STUB_PORT}/slcan.c
               ${HIL_STUB_PORT}/socketcand.c ${HIL_STUB_PORT}/socketcan.c)
target_compile_options(hil_stub PRIVATE ${HIL_STRICT_FLAGS})
target_link_libraries(hil_stub PRIVATE hil_fw)

# Benchmark helper: raw pty round trip of two C processes (bench/perf/loop.py compares to it).
add_executable(pty_pingpong ${HIL_ROOT}/bench/perf/pty_pingpong.c)
target_compile_options(pty_pingpong PRIVATE -Wall -Wextra -Werror)
target_link_libraries(pty_pingpong PRIVATE util)

# Benchmark helper: timer wake-up latency of a periodic thread (docs/realtime.md; cyclictest's
# measurement plus the engine's spin before each deadline).
add_executable(wakeup_latency ${HIL_ROOT}/bench/perf/wakeup_latency.c)
target_compile_options(wakeup_latency PRIVATE -Wall -Wextra -Werror)

# C tests of the firmware: one executable per tests/c/test_fw_*.c, run by CTest.
file(GLOB HIL_FW_TESTS CONFIGURE_DEPENDS ${HIL_ROOT}/tests/c/test_fw_*.c)
foreach(test_src ${HIL_FW_TESTS})
  get_filename_component(test_name ${test_src} NAME_WE)
  add_executable(${test_name} ${test_src})
  target_compile_options(${test_name} PRIVATE ${HIL_STRICT_FLAGS})
  target_link_libraries(${test_name} PRIVATE hil_fw)
  target_include_directories(${test_name} PRIVATE ${HIL_ROOT}/tests/c)
  add_test(NAME ${test_name} COMMAND ${test_name} ${HIL_ROOT})
endforeach()
add_test(NAME firmware_no_8bit_types
  COMMAND ${CMAKE_COMMAND} -DHIL_PROTOCOL_DIR=${HIL_ROOT}/firmware_stub/src
          -P ${HIL_ROOT}/protocol/c/check_no_8bit_types.cmake)
