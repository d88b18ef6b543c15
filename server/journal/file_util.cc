#include "server/journal/file_util.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>

namespace slamd::server::internal {

std::string ErrnoDescription(int err) {
  const char* name = nullptr;
  switch (err) {
    case ENOSPC:
      name = "ENOSPC";
      break;
    case EFBIG:
      name = "EFBIG";
      break;
    case EDQUOT:
      name = "EDQUOT";
      break;
    case EIO:
      name = "EIO";
      break;
    case EROFS:
      name = "EROFS";
      break;
    case EACCES:
      name = "EACCES";
      break;
    case ENOENT:
      name = "ENOENT";
      break;
    case EINTR:
      name = "EINTR";
      break;
    default:
      break;
  }
  std::string s = std::strerror(err);
  s += name != nullptr ? std::string(" (") + name + ")" : " (errno " + std::to_string(err) + ")";
  return s;
}

std::string DirName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

core::Status CreateDataDirectory(const std::string& dir, bool* loose) {
  if (dir.empty()) return core::InvalidArgument("data directory: empty path");
  struct stat st {};
  if (::stat(dir.c_str(), &st) == 0) {
    if (!S_ISDIR(st.st_mode)) return core::IoError("data directory " + dir + ": not a directory");
    if (loose != nullptr) *loose = (st.st_mode & 0077) != 0;
    return core::Status::Ok();
  }
  if (errno != ENOENT) {
    return core::IoError("data directory " + dir + ": " + ErrnoDescription(errno));
  }
  if (const std::string parent = DirName(dir); parent != dir && parent != "." && parent != "/") {
    SLAMD_RETURN_IF_ERROR(CreateDataDirectory(parent, nullptr));
  }
  // mkdir applies the umask; the mode is set again so that a permissive umask cannot widen it.
  if (::mkdir(dir.c_str(), kDataDirMode) != 0 && errno != EEXIST) {
    return core::IoError("cannot create data directory " + dir + ": " + ErrnoDescription(errno));
  }
  if (::chmod(dir.c_str(), kDataDirMode) != 0) {
    return core::IoError("cannot set the mode of data directory " + dir + ": " +
                         ErrnoDescription(errno));
  }
  if (loose != nullptr) *loose = false;
  return core::Status::Ok();
}

core::Status SyncDirectory(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) {
    return core::IoError("cannot open directory " + dir +
                         " to sync it: " + ErrnoDescription(errno));
  }
  const int r = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (r != 0)
    return core::IoError("fsync of directory " + dir + " failed: " + ErrnoDescription(err));
  return core::Status::Ok();
}

core::Status PwriteAll(int fd, const char* data, std::size_t n, int64_t offset,
                       const std::string& path, const char* what, std::size_t* written) {
  std::size_t done = 0;
  while (done < n) {
    const ssize_t r = ::pwrite(fd, data + done, n - done, static_cast<off_t>(offset + done));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) {
      // r == 0 makes no progress; report it like an error rather than spin.
      const int err = r < 0 ? errno : EIO;
      if (written != nullptr) *written = done;
      return core::IoError("write of " + std::string(what) + " to " + path + " at offset " +
                           std::to_string(offset) + " failed after " + std::to_string(done) +
                           " of " + std::to_string(n) + " bytes: " + ErrnoDescription(err));
    }
    done += static_cast<std::size_t>(r);
  }
  if (written != nullptr) *written = done;
  return core::Status::Ok();
}

int64_t PreadUpTo(int fd, char* out, std::size_t n, int64_t offset) {
  std::size_t done = 0;
  while (done < n) {
    const ssize_t r = ::pread(fd, out + done, n - done, static_cast<off_t>(offset + done));
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) return -1;
    if (r == 0) break;
    done += static_cast<std::size_t>(r);
  }
  return static_cast<int64_t>(done);
}

std::string NumberedName(std::string_view prefix, int64_t number, std::string_view suffix) {
  char digits[32];
  std::snprintf(digits, sizeof(digits), "%020lld", static_cast<long long>(number));
  return std::string(prefix) + digits + std::string(suffix);
}

int64_t ParseNumberedName(std::string_view name, std::string_view prefix, std::string_view suffix) {
  constexpr std::size_t kDigits = 20;
  if (name.size() != prefix.size() + kDigits + suffix.size()) return -1;
  if (name.substr(0, prefix.size()) != prefix) return -1;
  if (name.substr(name.size() - suffix.size()) != suffix) return -1;
  int64_t number = 0;
  for (std::size_t i = prefix.size(); i < prefix.size() + kDigits; ++i) {
    if (name[i] < '0' || name[i] > '9') return -1;
    if (number > (INT64_MAX - 9) / 10) return -1;
    number = number * 10 + (name[i] - '0');
  }
  return number;
}

}  // namespace slamd::server::internal
