// The sanitizers' default options, compiled into every executable of a sanitizer build (-DGPISVDB_SANITIZE=...):
// tools/sanitize, CTest (the Catch2 discovery run included) and a plain run of build-asan/bin/gpisvdb all stop at
// the first report with the suppressions of this folder, without any environment. ASAN_OPTIONS, UBSAN_OPTIONS,
// LSAN_OPTIONS and TSAN_OPTIONS still override them, option by option.
#ifndef GPISVDB_SANITIZER_DIR
#error "GPISVDB_SANITIZER_DIR (this folder) must be defined"
#endif

#define GPISVDB_SANITIZER_CALLBACK extern "C" __attribute__((used, visibility("default"), no_sanitize_address))

// Every report halts the process with a non-zero exit code, so the test that triggered it fails.
GPISVDB_SANITIZER_CALLBACK const char* __asan_default_options() {
    return "halt_on_error=1:detect_leaks=1:strict_string_checks=1:check_initialization_order=1";
}
GPISVDB_SANITIZER_CALLBACK const char* __ubsan_default_options() { return "halt_on_error=1:print_stacktrace=1"; }
GPISVDB_SANITIZER_CALLBACK const char* __lsan_default_options() {
    return "suppressions=" GPISVDB_SANITIZER_DIR "/lsan.supp:print_suppressions=0";
}
GPISVDB_SANITIZER_CALLBACK const char* __tsan_default_options() {
    return "halt_on_error=1:second_deadlock_stack=1:suppressions=" GPISVDB_SANITIZER_DIR "/tsan.supp";
}

#if defined(__SANITIZE_ADDRESS__)
#include <dlfcn.h>
// LeakSanitizer and Mesa: rendering (VTK under Xvfb) makes libGLX load Mesa's software driver swrast_dri.so and
// dlclose it when the display closes. The driver keeps a few allocations (240 bytes) in its own globals; once it
// is unloaded LeakSanitizer sees them unreferenced, with frames in an "<unknown module>" that no suppression can
// name. Keeping the driver loaded for the life of the process (RTLD_NODELETE; ~0.1 s) leaves them reachable, so
// leaks in our code are still reported. Nothing happens where the driver is not installed.
__attribute__((constructor)) static void gpisvdbKeepMesaDriverLoaded() {
    dlopen("/usr/lib/x86_64-linux-gnu/dri/swrast_dri.so", RTLD_LAZY | RTLD_LOCAL | RTLD_NODELETE);
}
#endif
