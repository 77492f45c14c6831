// Per-function code generation for the Q16.16 Uno image, whose build defines SMA_IRA_PRIORITY
// (firmware/CMakeLists.txt: built with -fira-algorithm=priority). Code generation only: the
// numbers a function computes are the same with it or without.
//
// SMA_OWN_OPTIONS: the register allocator's default (Chaitin-Briggs) colouring on one function,
// which avr-gcc 5.4 then compiles with an option set of its own. On Store::crc_ok, set_value and
// Params::check() the allocator is what shrinks them; on Pid::step and poll_serial the own option
// set is (-fno-tree-pre or -fno-tree-dominator-opts in its place give the same bytes). Not on
// functions with callees inlined into them: GCC 5 does not inline across different option sets
// (docs/board.md "Session 13, qattr" has the scan). Empty on the float image (+10 B on
// Params::check()) and everywhere else.
#ifndef SMA_CODEGEN_HPP
#define SMA_CODEGEN_HPP

#if defined(__AVR__) && defined(SMA_IRA_PRIORITY)
#define SMA_OWN_OPTIONS __attribute__((optimize("-fira-algorithm=CB")))
#else
#define SMA_OWN_OPTIONS
#endif

#endif  // SMA_CODEGEN_HPP
