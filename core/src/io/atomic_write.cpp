// write_file_atomically: temporary file beside the target, then rename over it, so a
// reader never sees a half-written file and a failure never touches the old target.
// Live temporary files are listed in a fixed table that a SIGINT/SIGTERM/SIGHUP handler
// empties (unlink only: async-signal-safe) before the signal takes its default course.
#include "picoscan/error.h"
#include "picoscan/file_output.h"

#include <atomic>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <system_error>
#include <utility>
#include <vector>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace picoscan {

namespace fs = std::filesystem;

namespace {

std::atomic<unsigned long long> temp_counter{0};

// The registry of live temporary files. A slot is Free, being Written by a thread, or Live
// (its path complete, for the handler to unlink). More live files than slots (many writer
// threads) are still written; only those are not removed by a signal.
constexpr int kSlots = 256;
enum SlotState : int { Free = 0, Writing = 1, Live = 2 };
// Every member has its initial value (all zero), so the registry is initialised at compile
// time: no code at start-up writes to each of its 256 pages.
struct Slot {
    std::atomic<int> state{Free};
    char path[PATH_MAX]{};
};
Slot slots[kSlots];
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler reads the slots' state");

extern "C" void remove_temporaries_and_reraise(int signal_number) {
    for (Slot& slot : slots)
        if (slot.state.load() == Live) ::unlink(slot.path);
    // The default action then ends the process with the signal's usual status.
    ::signal(signal_number, SIG_DFL);
    ::raise(signal_number);
}

// Installed on the first write, only for signals whose action is still the default: a host
// (Python, FreeCAD, MeshLab) that handles a signal keeps doing so, and its own interruption
// unwinds through the guards below.
void install_signal_handlers() {
    static std::once_flag once;
    std::call_once(once, [] {
        for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
            struct sigaction current {};
            if (::sigaction(signal_number, nullptr, &current) != 0 || current.sa_handler != SIG_DFL ||
                (current.sa_flags & SA_SIGINFO))
                continue;
            struct sigaction action {};
            action.sa_handler = remove_temporaries_and_reraise;
            sigemptyset(&action.sa_mask);
            ::sigaction(signal_number, &action, nullptr);
        }
    });
}

int register_temporary(const std::string& path) {
    if (path.size() >= PATH_MAX) return -1;
    for (int index = 0; index < kSlots; ++index) {
        int expected = Free;
        if (slots[index].state.compare_exchange_strong(expected, Writing)) {
            std::memcpy(slots[index].path, path.c_str(), path.size() + 1);
            slots[index].state.store(Live);
            return index;
        }
    }
    return -1;
}

void unregister_temporary(int index) {
    if (index >= 0) slots[index].state.store(Free);
}

// Registered before the file is created (so a signal never misses it), the temporary file
// is removed unless released (after the successful rename).
class TempFileGuard {
public:
    explicit TempFileGuard(std::string path) : path_(std::move(path)), slot_(register_temporary(path_)) {}
    ~TempFileGuard() {
        if (fd_ >= 0) ::close(fd_);
        if (created_ && !path_.empty()) ::unlink(path_.c_str());
        unregister_temporary(slot_);
    }
    TempFileGuard(const TempFileGuard&) = delete;
    TempFileGuard& operator=(const TempFileGuard&) = delete;

    // The descriptor of the created file; a name O_EXCL found taken is never unlinked.
    void set_fd(int fd) {
        fd_ = fd;
        created_ = true;
    }
    // Closes the descriptor; returns 0 or the errno of a failed close.
    int close_fd() {
        const int fd = fd_;
        fd_ = -1;
        return ::close(fd) == 0 ? 0 : errno;
    }
    void release() { path_.clear(); }

private:
    std::string path_;
    int slot_ = -1;
    int fd_ = -1;
    bool created_ = false;
};

std::string errno_text(int error) { return std::strerror(error); }

// The OutputBatch in force (at most one), and the files it holds back.
struct PendingOutput {
    std::string temp, target;
    int slot = -1;
};
std::mutex batch_mutex;
std::vector<PendingOutput>* active_batch = nullptr;

void rename_into_place(const std::string& temp, const std::string& path) {
    std::error_code error;
    fs::rename(temp, path, error);
    if (error) throw Error(path, "cannot rename temporary file into place: " + error.message());
}

}  // namespace

void write_file_atomically(const std::string& path, const std::string& bytes) {
    if (path.empty()) throw Error(path, "cannot write a file with an empty path");
    install_signal_handlers();

    const std::string temp = path + ".tmp-" + std::to_string(::getpid()) + "-" +
                             std::to_string(temp_counter.fetch_add(1));
    TempFileGuard guard(temp);
    // O_EXCL: never write into a file somebody else owns.
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0)
        throw Error(path, "cannot create temporary file " + temp + ": " + errno_text(errno));
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

    {
        std::lock_guard<std::mutex> lock(batch_mutex);
        if (active_batch) {
            for (const PendingOutput& pending : *active_batch)
                if (pending.target == path) throw Error(path, "is written twice by one command");
            active_batch->push_back({temp, path, register_temporary(temp)});
            guard.release();  // the batch holds the file now
            return;
        }
    }
    rename_into_place(temp, path);
    guard.release();
}

OutputBatch::OutputBatch() {
    std::lock_guard<std::mutex> lock(batch_mutex);
    if (active_batch) throw Error("outputs", "one batch of outputs is already being written");
    active_batch = new std::vector<PendingOutput>();
}

OutputBatch::~OutputBatch() {
    std::lock_guard<std::mutex> lock(batch_mutex);
    if (!active_batch) return;
    for (const PendingOutput& pending : *active_batch) {
        ::unlink(pending.temp.c_str());
        unregister_temporary(pending.slot);
    }
    delete active_batch;
    active_batch = nullptr;
}

void OutputBatch::commit() {
    std::vector<PendingOutput> pending;
    {
        std::lock_guard<std::mutex> lock(batch_mutex);
        if (!active_batch) return;
        pending.swap(*active_batch);
        delete active_batch;
        active_batch = nullptr;
    }
    // 1. Each old output gets a second name (a hard link: the old file stays where it is), so
    //    that a failure later can put it back. 2. The new files are renamed into place. 3. The
    //    second names are removed. A failure in 1 or 2 renames every old file back and removes
    //    the new ones that had no old one: the old set stays whole. The backups carry ".tmp-"
    //    and are registered, so a signal removes them like temporary files.
    struct Backup {
        std::string path;
        int slot = -1;
    };
    std::vector<Backup> backups(pending.size());
    std::string failure;
    size_t renamed = 0;
    for (size_t index = 0; index < pending.size() && failure.empty(); ++index) {
        const std::string& target = pending[index].target;
        struct stat status {};
        if (::lstat(target.c_str(), &status) != 0 || S_ISDIR(status.st_mode)) continue;  // nothing to keep
        const std::string backup = target + ".tmp-" + std::to_string(::getpid()) + "-" +
                                   std::to_string(temp_counter.fetch_add(1)) + ".old";
        backups[index] = {backup, register_temporary(backup)};
        if (::link(target.c_str(), backup.c_str()) != 0) {
            failure = target + ": cannot keep the old file while the new set is written: " + errno_text(errno);
            unregister_temporary(backups[index].slot);
            backups[index] = {};
        }
    }
    while (renamed < pending.size() && failure.empty()) {
        try {
            rename_into_place(pending[renamed].temp, pending[renamed].target);
            ++renamed;
        } catch (const Error& error) {
            failure = error.what();
        }
    }
    if (!failure.empty()) {
        // Rolled back: renamed targets get their old file back (or are removed if there was none).
        for (size_t index = 0; index < renamed; ++index) {
            if (!backups[index].path.empty()) ::rename(backups[index].path.c_str(), pending[index].target.c_str());
            else ::unlink(pending[index].target.c_str());
        }
        for (size_t index = renamed; index < pending.size(); ++index) ::unlink(pending[index].temp.c_str());
    }
    for (size_t index = 0; index < pending.size(); ++index) {
        if (!backups[index].path.empty()) ::unlink(backups[index].path.c_str());  // gone already if restored
        unregister_temporary(backups[index].slot);
        unregister_temporary(pending[index].slot);
    }
    if (!failure.empty()) throw Error("outputs", failure + "; the old outputs were left as they were");
}

}  // namespace picoscan
