// Serialises progress reports from worker threads and remembers a cancel request.
#pragma once

#include "picoscan/progress.h"

#include <atomic>
#include <mutex>
#include <string>

namespace picoscan::detail {

class ProgressReporter {
public:
    ProgressReporter(const ProgressCallback& callback, std::string stage, int total)
        : callback_(callback), stage_(std::move(stage)), total_(total > 0 ? total : 1) {}

    // Adds `count` units of work done; returns false once the user asked to stop.
    bool advance(int count = 1) {
        if (!callback_) return !cancelled_;
        // Counted under the lock, so reports never go backwards.
        std::lock_guard<std::mutex> lock(mutex_);
        done_ += count;
        if (!cancelled_ && !callback_(double(done_) / total_, stage_)) cancelled_ = true;
        return !cancelled_;
    }
    bool cancelled() const { return cancelled_; }

private:
    const ProgressCallback& callback_;
    std::string stage_;
    int total_;
    int done_ = 0;
    std::atomic<bool> cancelled_{false};
    std::mutex mutex_;
};

}  // namespace picoscan::detail
