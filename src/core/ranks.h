#pragma once
// The processes one run is spread over (docs/design.md, Pipeline): MPI ranks under mpirun
// (app/mpi_ranks.cpp), or none. The pipeline asks only for these collective operations, so MPI's
// headers stay in app/. Every rank must call each operation in the same order.

#include "core/error.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace fogmap {

class Ranks {
public:
    virtual ~Ranks() = default;
    virtual int rank() const = 0;
    virtual int size() const = 0;
    /// Element-wise integer sum of `values` over all ranks, left on rank 0 (other ranks' values
    /// are unspecified after the call). Integer sums do not depend on the order of arrival.
    virtual void sum_to_root(std::vector<int64_t>* values) = 0;
    /// Element-wise integer sum of `values` over all ranks, on every rank (MPI_Allreduce).
    virtual void sum_to_all(std::vector<int64_t>* values) = 0;
    /// Every rank's `mine`, in rank order, on every rank (MPI_Allgatherv): how the ranks sharing
    /// a photon pass see each other's chunks.
    virtual std::vector<std::vector<uint8_t>> all_gather(const std::vector<uint8_t>& mine) = 0;
    /// True on every rank when any rank passes true.
    virtual bool any(bool mine) = 0;
    /// Waits until every rank has called it, sleeping meanwhile (MPI_Ibarrier polled every
    /// millisecond): a rank left out of a measurement leaves its cores to the others.
    virtual void wait_all() = 0;
    /// How many of these ranks run on this rank's machine (MPI_COMM_TYPE_SHARED).
    virtual int on_this_machine() = 0;
    /// The ranks passing the same `group` as this one, ranked as here (MPI_Comm_split): the
    /// groups a sequence's frames are dealt to. Collective.
    virtual std::unique_ptr<Ranks> split(int group) = 0;
};

/// Runs f() on every rank where reading input may fail on some ranks only (a data file missing
/// on one machine): when f throws InputError on any rank, every rank throws the error of the
/// lowest such rank (naming it when it is not rank 0), so all exit with 2 and rank 0 says it
/// once, rather than the others waiting for the failed rank forever. Collective; without ranks,
/// just f().
template <class F>
void agree_on_input(Ranks* ranks, F&& f) {
    if (!ranks || ranks->size() == 1) {
        f();
        return;
    }
    std::string mine;
    try {
        f();
    } catch (const InputError& e) {
        mine = e.file + '\0' + e.field + '\0' + e.reason;
    }
    const std::vector<std::vector<uint8_t>> all =
        ranks->all_gather(std::vector<uint8_t>(mine.begin(), mine.end()));
    for (size_t r = 0; r < all.size(); ++r) {
        if (all[r].empty()) continue;
        const std::string text(all[r].begin(), all[r].end());
        const size_t a = text.find('\0'), b = text.find('\0', a + 1);
        throw InputError(
            text.substr(0, a), text.substr(a + 1, b - a - 1),
            text.substr(b + 1) + (r == 0 ? "" : " (on MPI rank " + std::to_string(r) + ")"));
    }
}

}  // namespace fogmap
