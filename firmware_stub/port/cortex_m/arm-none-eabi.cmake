# CMake toolchain file: GNU Arm Embedded (Debian's gcc-arm-none-eabi + libnewlib-arm-none-eabi)
# for a Cortex-M4F with its single-precision FPU, hard-float ABI.
#   cmake -S firmware_stub/port/cortex_m -B build/cortex_m \
#         -DCMAKE_TOOLCHAIN_FILE=firmware_stub/port/cortex_m/arm-none-eabi.cmake
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_ASM_COMPILER arm-none-eabi-gcc)
find_program(HIL_ARM_SIZE arm-none-eabi-size)
find_program(HIL_ARM_OBJCOPY arm-none-eabi-objcopy)
# no host executable can run a bare-metal link: compiler checks build a static library
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(HIL_CPU_FLAGS -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard)
string(REPLACE ";" " " _hil_cpu "${HIL_CPU_FLAGS}")
set(CMAKE_C_FLAGS_INIT "${_hil_cpu} -ffunction-sections -fdata-sections")
set(CMAKE_EXE_LINKER_FLAGS_INIT "${_hil_cpu} --specs=nano.specs -nostartfiles -Wl,--gc-sections")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
