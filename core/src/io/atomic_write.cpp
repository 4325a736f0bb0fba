// write_file_atomically: temporary file beside the target, then rename over it, so a
// reader never sees a half-written file and a failure never touches the old target.
#include "picoscan/error.h"
#include "picoscan/file_output.h"

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include <fcntl.h>
#include <unistd.h>

namespace picoscan {

namespace fs = std::filesystem;

namespace {

std::atomic<unsigned long long> temp_counter{0};

// Removes the temporary file unless released (after the successful rename).
class TempFileGuard {
public:
    explicit TempFileGuard(std::string path) : path_(std::move(path)) {}
    ~TempFileGuard() {
        if (fd_ >= 0) ::close(fd_);
        if (!path_.empty()) ::unlink(path_.c_str());
    }
    TempFileGuard(const TempFileGuard&) = delete;
    TempFileGuard& operator=(const TempFileGuard&) = delete;

    void set_fd(int fd) { fd_ = fd; }
    // Closes the descriptor; returns 0 or the errno of a failed close.
    int close_fd() {
        const int fd = fd_;
        fd_ = -1;
        return ::close(fd) == 0 ? 0 : errno;
    }
    void release() { path_.clear(); }

private:
    std::string path_;
    int fd_ = -1;
};

std::string errno_text(int error) { return std::strerror(error); }

}  // namespace

void write_file_atomically(const std::string& path, const std::string& bytes) {
    if (path.empty()) throw Error(path, "cannot write a file with an empty path");

    const std::string temp = path + ".tmp-" + std::to_string(::getpid()) + "-" +
                             std::to_string(temp_counter.fetch_add(1));
    // O_EXCL: never write into a file somebody else owns.
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0)
        throw Error(path, "cannot create temporary file " + temp + ": " + errno_text(errno));
    TempFileGuard guard(temp);
    guard.set_fd(fd);

    const char* data = bytes.data();
    size_t left = bytes.size();
    while (left > 0) {
        const ssize_t written = ::write(fd, data, left);
        if (written < 0) {
            if (errno == EINTR) continue;
            throw Error(path, "write failed: " + errno_text(errno));
        }
        data += written;
        left -= static_cast<size_t>(written);
    }
    // Data on disk before the rename makes it visible; a crash then leaves old or new.
    if (::fsync(fd) != 0 && errno != EINVAL && errno != EROFS)
        throw Error(path, "fsync failed: " + errno_text(errno));
    if (const int close_error = guard.close_fd())
        throw Error(path, "close failed: " + errno_text(close_error));

    std::error_code error;
    fs::rename(temp, path, error);
    if (error) throw Error(path, "cannot rename temporary file into place: " + error.message());
    guard.release();
}

}  // namespace picoscan
