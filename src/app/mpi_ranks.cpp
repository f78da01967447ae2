#include "app/mpi_ranks.h"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <thread>
#include <vector>

namespace fogmap {

namespace {

/// Values per reduce: 2^24, or FOGMAP_MPI_CHUNK (1 .. 2^24) where set, so that tests make small
/// films span many chunks.
size_t reduce_chunk() {
    constexpr size_t kChunk = size_t(1) << 24;
    static const size_t chunk = [] {
        const char* env = std::getenv("FOGMAP_MPI_CHUNK");
        const long long v = env ? std::atoll(env) : 0;
        return v >= 1 && v <= static_cast<long long>(kChunk) ? static_cast<size_t>(v) : kChunk;
    }();
    return chunk;
}

class MpiRanks final : public Ranks {
public:
    /// The world (finalised with it), or a communicator split from it (freed with it).
    explicit MpiRanks(MPI_Comm comm = MPI_COMM_WORLD) : comm_(comm) {
        MPI_Comm_rank(comm_, &rank_);
        MPI_Comm_size(comm_, &size_);
    }
    ~MpiRanks() override {
        if (comm_ == MPI_COMM_WORLD)
            MPI_Finalize();
        else
            MPI_Comm_free(&comm_);
    }
    std::unique_ptr<Ranks> split(int group) override {
        MPI_Comm sub;
        MPI_Comm_split(comm_, group, rank_, &sub);
        return std::make_unique<MpiRanks>(sub);
    }
    int rank() const override { return rank_; }
    int size() const override { return size_; }
    // In chunks: MPI counts are ints, and a 1920x1080 film with its layers is 44 million values.
    void sum_to_root(std::vector<int64_t>* values) override {
        const size_t chunk = reduce_chunk();
        std::vector<int64_t> out(rank_ == 0 ? values->size() : 0);
        for (size_t at = 0; at < values->size(); at += chunk) {
            const int n = static_cast<int>(std::min(chunk, values->size() - at));
            MPI_Reduce(values->data() + at, rank_ == 0 ? out.data() + at : nullptr, n, MPI_INT64_T,
                       MPI_SUM, 0, comm_);
        }
        if (rank_ == 0) *values = std::move(out);
    }
    void sum_to_all(std::vector<int64_t>* values) override {
        const size_t chunk = reduce_chunk();
        for (size_t at = 0; at < values->size(); at += chunk) {
            const int n = static_cast<int>(std::min(chunk, values->size() - at));
            MPI_Allreduce(MPI_IN_PLACE, values->data() + at, n, MPI_INT64_T, MPI_SUM, comm_);
        }
    }
    // In pieces of at most 2^30 bytes over all ranks: MPI counts and displacements are ints.
    std::vector<std::vector<uint8_t>> all_gather(const std::vector<uint8_t>& mine) override {
        const uint64_t n = mine.size();
        std::vector<uint64_t> sizes(size_);
        MPI_Allgather(&n, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, comm_);
        std::vector<std::vector<uint8_t>> out(size_);
        for (int q = 0; q < size_; ++q) out[q].resize(sizes[q]);
        const uint64_t piece = (uint64_t(1) << 30) / uint64_t(size_);
        std::vector<int> counts(size_), displs(size_);
        std::vector<uint8_t> buffer;
        for (uint64_t at = 0;; at += piece) {
            int total = 0;
            for (int q = 0; q < size_; ++q) {
                counts[q] = int(sizes[q] > at ? std::min(piece, sizes[q] - at) : 0);
                displs[q] = total;
                total += counts[q];
            }
            if (total == 0) break;
            buffer.resize(size_t(total));
            MPI_Allgatherv(mine.data() + std::min(at, n), counts[rank_], MPI_BYTE, buffer.data(),
                           counts.data(), displs.data(), MPI_BYTE, comm_);
            for (int q = 0; q < size_; ++q)
                std::copy_n(buffer.data() + displs[q], counts[q], out[q].data() + at);
        }
        return out;
    }
    void wait_all() override {
        MPI_Request request;
        MPI_Ibarrier(comm_, &request);
        for (int done = 0;;) {
            MPI_Test(&request, &done, MPI_STATUS_IGNORE);
            if (done) return;
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
    }
    int on_this_machine() override {
        MPI_Comm local;
        MPI_Comm_split_type(comm_, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &local);
        int n = 1;
        MPI_Comm_size(local, &n);
        MPI_Comm_free(&local);
        return n;
    }
    bool any(bool mine) override {
        int in = mine ? 1 : 0, out = 0;
        MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_LOR, comm_);
        return out != 0;
    }

private:
    MPI_Comm comm_;
    int rank_ = 0, size_ = 1;
};

}  // namespace

std::unique_ptr<Ranks> start_mpi(int* argc, char*** argv) {
    // Open MPI's launcher sets these; without them fogmap is one process without MPI.
    if (!std::getenv("OMPI_COMM_WORLD_SIZE") && !std::getenv("PMIX_RANK")) return nullptr;
    int provided = 0;
    MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
    return std::make_unique<MpiRanks>();
}

void abort_mpi(int code) {
    int initialized = 0, finalized = 0;
    MPI_Initialized(&initialized);
    MPI_Finalized(&finalized);
    if (initialized && !finalized) MPI_Abort(MPI_COMM_WORLD, code);
    std::exit(code);
}

}  // namespace fogmap
