// SLAMD_GLIBC_MALLOC: 1 when the process's malloc is glibc's own, whose statistics (mallinfo2,
// malloc_stats) the memory tests read; 0 elsewhere and under ASan or TSan, which replace malloc
// (mallinfo2 then reports nothing).
#pragma once

#if defined(__GLIBC__)
#if defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define SLAMD_GLIBC_MALLOC 0
#endif
#endif
#if !defined(SLAMD_GLIBC_MALLOC) && (defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__))
#define SLAMD_GLIBC_MALLOC 0
#endif
#ifndef SLAMD_GLIBC_MALLOC
#define SLAMD_GLIBC_MALLOC 1
#endif
#else
#define SLAMD_GLIBC_MALLOC 0
#endif
