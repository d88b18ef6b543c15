// Small POSIX file helpers shared by the journal and snapshot files (internal).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "core/base/status.h"

namespace slamd::server::internal {

// "No space left on device (ENOSPC)": strerror plus the errno name for the common I/O errors.
std::string ErrnoDescription(int err);

// The directory part of a path ("." when there is none).
std::string DirName(const std::string& path);

// "<prefix><number, 20 digits zero-padded><suffix>": the names of journal segments and
// snapshots (zero-padded: names sort by number), and the number such a name holds, -1 when
// `name` is not one.
std::string NumberedName(std::string_view prefix, int64_t number, std::string_view suffix);
int64_t ParseNumberedName(std::string_view name, std::string_view prefix, std::string_view suffix);

// Journal segments and snapshots hold every robot's data: owner-only, as is the data directory
// slamd creates for them.
inline constexpr unsigned kDataFileMode = 0600;
inline constexpr unsigned kDataDirMode = 0700;

// Creates `dir` and its missing parents; the ones it creates get kDataDirMode. An existing
// directory is left as it is; *loose (if not null) is set when group or others can enter it.
core::Status CreateDataDirectory(const std::string& dir, bool* loose);

// fsync of a directory, so a created, renamed or removed entry in it is durable.
core::Status SyncDirectory(const std::string& dir);

// Writes all n bytes at `offset` with pwrite (retrying EINTR and short writes). On failure
// returns IoError naming `what`, the path, the offset reached and the cause; *written (if not
// null) gets how many bytes did reach the file.
core::Status PwriteAll(int fd, const char* data, std::size_t n, int64_t offset,
                       const std::string& path, const char* what, std::size_t* written);

// Reads up to n bytes at `offset` with pread (retrying EINTR and short reads until EOF).
// Returns the number of bytes read (< n only at end of file), or -1 with errno set.
int64_t PreadUpTo(int fd, char* out, std::size_t n, int64_t offset);

}  // namespace slamd::server::internal
