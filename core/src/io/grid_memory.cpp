// Camera-sized grids (1600x1200 of 3 floats is 23 MB) hold a view's few percent of measured
// pixels. Filled through ordinary memory, every 4 KB page of them is faulted in and written,
// which cost more than the registration of a pair. Here large grids come from fresh anonymous
// mappings: they read as zero without being written, and pages are asked for as 2 MB huge
// pages, so a grid is faulted in a few dozen times instead of thousands.
#include "io/io_detail.h"

#include <sys/mman.h>

#include <limits>
#include <mutex>
#include <new>
#include <vector>

namespace picoscan::detail {

namespace {

constexpr size_t kMappedFromBytes = size_t(1) << 20;  // smaller grids: ordinary cv::Mat memory

class MappedAllocator : public cv::MatAllocator {
public:
    cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, size_t* step, cv::AccessFlag,
                           cv::UMatUsageFlags) const override {
        CV_Assert(data == nullptr);  // only grids this allocator creates itself
        size_t bytes = CV_ELEM_SIZE(type);
        for (int i = dims - 1; i >= 0; --i) {
            if (step) step[i] = bytes;
            bytes *= static_cast<size_t>(sizes[i]);
        }
        void* mapping = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (mapping == MAP_FAILED) throw std::bad_alloc();
        madvise(mapping, bytes, MADV_HUGEPAGE);  // advice only: without huge pages it still works
        cv::UMatData* u = new cv::UMatData(this);
        u->data = u->origdata = static_cast<uchar*>(mapping);
        u->size = bytes;
        return u;
    }
    bool allocate(cv::UMatData* u, cv::AccessFlag, cv::UMatUsageFlags) const override { return u != nullptr; }
    void deallocate(cv::UMatData* u) const override {
        if (!u) return;
        munmap(u->origdata, u->size);
        delete u;
    }
};

// Grids that are written whole (the NaN of every unmeasured point) need no fresh pages: the
// last two freed ones are kept and handed out again, so reading view after view does not
// fault in (a fault per 4 KB on this kind of virtual machine, huge pages or not) and clear
// 23 MB for each view, only to overwrite it.
class RecyclingAllocator : public cv::MatAllocator {
public:
    // The kept grids go at exit (LeakSanitizer counted their two headers as leaks in every
    // stitch and failed it).
    ~RecyclingAllocator() override {
        for (cv::UMatData* u : kept_) fresh_.deallocate(u);
    }
    cv::UMatData* allocate(int dims, const int* sizes, int type, void* data, size_t* step, cv::AccessFlag flags,
                           cv::UMatUsageFlags usage) const override {
        CV_Assert(data == nullptr);  // only grids this allocator creates itself
        size_t bytes = CV_ELEM_SIZE(type);
        for (int i = dims - 1; i >= 0; --i) {
            if (step) step[i] = bytes;
            bytes *= static_cast<size_t>(sizes[i]);
        }
        {
            std::lock_guard<std::mutex> lock(mutex_);
            for (auto kept = kept_.begin(); kept != kept_.end(); ++kept)
                if ((*kept)->size == bytes) {
                    cv::UMatData* u = *kept;
                    kept_.erase(kept);
                    return u;
                }
        }
        cv::UMatData* u = fresh_.allocate(dims, sizes, type, nullptr, step, flags, usage);
        u->currAllocator = u->prevAllocator = this;
        return u;
    }
    bool allocate(cv::UMatData* u, cv::AccessFlag, cv::UMatUsageFlags) const override { return u != nullptr; }
    void deallocate(cv::UMatData* u) const override {
        if (!u) return;
        std::lock_guard<std::mutex> lock(mutex_);
        kept_.push_back(u);
        if (kept_.size() <= kKept) return;
        fresh_.deallocate(kept_.front());
        kept_.erase(kept_.begin());
    }

private:
    static constexpr size_t kKept = 2;
    MappedAllocator fresh_;
    mutable std::mutex mutex_;
    mutable std::vector<cv::UMatData*> kept_;
};

}  // namespace

cv::Mat nan_grid(int rows, int cols, int type) {
    cv::Mat grid;
    if (static_cast<size_t>(rows) * static_cast<size_t>(cols) * CV_ELEM_SIZE(type) >= kMappedFromBytes) {
        static RecyclingAllocator allocator;  // outlives every grid: deallocation goes through it
        grid.allocator = &allocator;
    }
    grid.create(rows, cols, type);
    grid.setTo(cv::Scalar::all(std::numeric_limits<float>::quiet_NaN()));
    return grid;
}

cv::Mat zeroed_grid(int rows, int cols, int type) {
    if (static_cast<size_t>(rows) * static_cast<size_t>(cols) * CV_ELEM_SIZE(type) < kMappedFromBytes)
        return cv::Mat::zeros(rows, cols, type);
    static MappedAllocator allocator;  // outlives every grid: deallocation goes through it
    cv::Mat grid;
    grid.allocator = &allocator;
    grid.create(rows, cols, type);
    return grid;
}

}  // namespace picoscan::detail
