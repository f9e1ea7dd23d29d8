// A parallel-for over one process-wide thread pool. The pool size is set once from --threads (default: all cores).
#pragma once
#include <cstdint>
#include <functional>

namespace bareskin {

// Sets the number of worker threads; 0 means one per core. Takes effect for later parallel_for calls.
void set_num_threads(int threads);
int num_threads();

// Calls body(chunk_begin, chunk_end) over [begin, end) split into chunks of at least `grain` items, on the pool.
// Blocks until every chunk is done; the first exception thrown by a chunk is rethrown here (the others are dropped).
// Called from inside a chunk it runs serially, so nesting never deadlocks.
void parallel_for(int64_t begin, int64_t end, const std::function<void(int64_t, int64_t)>& body, int64_t grain = 1);

// Makes the allocator keep freed memory for reuse, in one heap for all threads, instead of returning it to the system
// or giving each thread its own heap: jobs that allocate and free many large buffers on several threads (4K maps, net
// activations) otherwise pay a page fault for every fresh page, which on small VMs costs more than the arithmetic
// (make-dataset with 4K targets: bench/BENCHMARKS.md). The heap's first ~2 GB are given transparent huge pages, so
// fresh memory faults 2 MB at a time (makeup apply, relight: bench/BENCHMARKS.md). Call it before starting threads,
// in one-shot commands (run, evaluate, texgen make-dataset, makeup apply, relight).
void keep_freed_memory();

}  // namespace bareskin
