// Per-function code generation for the Q16.16 Uno image, whose build defines SMA_IRA_PRIORITY
// (firmware/CMakeLists.txt: built with -fira-algorithm=priority). Code generation only: the
// numbers a function computes are the same with it or without.
//
// SMA_OWN_OPTIONS: the register allocator's default (Chaitin-Briggs) colouring on one function.
// avr-gcc 5.4 then gives the function an option set of its own; on the functions that carry it
// that is what shrinks them, not the allocator (-fno-tree-pre or -fno-tree-dominator-opts in its
// place give the same bytes; docs/board.md "Session 13, qattr" has the scan). Elsewhere it does
// not pay: the float image (+10 B on Params::check()), the host.
#ifndef SMA_CODEGEN_HPP
#define SMA_CODEGEN_HPP

#if defined(__AVR__) && defined(SMA_IRA_PRIORITY)
#define SMA_OWN_OPTIONS __attribute__((optimize("-fira-algorithm=CB")))
#else
#define SMA_OWN_OPTIONS
#endif

#endif  // SMA_CODEGEN_HPP
