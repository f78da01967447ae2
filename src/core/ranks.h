#pragma once
// The processes one run is spread over (DESIGN.md, Ranks): MPI ranks under mpirun
// (app/mpi_ranks.cpp), or none. The pipeline asks only for these collective operations, so MPI's
// headers stay in app/. Every rank must call each operation in the same order.

#include <cstdint>
#include <memory>
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

}  // namespace fogmap
