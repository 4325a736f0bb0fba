// Camera-sized grids (1600x1200 of 3 floats is 23 MB) hold a view's few percent of measured
// pixels. Filled through ordinary memory, every 4 KB page of them is faulted in and written,
// which cost more than the registration of a pair. Here large grids come from fresh anonymous
// mappings: they read as zero without being written, and pages are asked for as 2 MB huge
// pages, so a grid is faulted in a few dozen times instead of thousands.
#include "io/io_detail.h"

#include <sys/mman.h>

#include <new>

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

}  // namespace

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
