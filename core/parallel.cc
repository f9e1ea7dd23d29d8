#include "core/parallel.h"

#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

namespace bareskin {
namespace {

thread_local bool in_worker = false;

class ThreadPool {
 public:
  explicit ThreadPool(int threads) {
    for (int i = 0; i < threads; ++i) {
      workers_.emplace_back([this] {
        in_worker = true;
        for (;;) {
          std::function<void()> task;
          {
            std::unique_lock<std::mutex> lock(mutex_);
            wake_.wait(lock, [this] { return stop_ || !tasks_.empty(); });
            if (stop_ && tasks_.empty()) return;
            task = std::move(tasks_.front());
            tasks_.pop_front();
          }
          task();
        }
      });
    }
  }
  ~ThreadPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (auto& w : workers_) w.join();
  }
  int size() const { return int(workers_.size()); }
  void submit(std::function<void()> task) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      tasks_.push_back(std::move(task));
    }
    wake_.notify_one();
  }

 private:
  std::vector<std::thread> workers_;
  std::deque<std::function<void()>> tasks_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
};

std::mutex pool_mutex;
int requested_threads = 0;  // 0: hardware concurrency
std::shared_ptr<ThreadPool> pool;

std::shared_ptr<ThreadPool> get_pool() {
  std::lock_guard<std::mutex> lock(pool_mutex);
  if (!pool) {
    pool = std::make_shared<ThreadPool>(requested_threads > 0 ? requested_threads
                                                              : int(std::max(1u, std::thread::hardware_concurrency())));
  }
  return pool;
}

}  // namespace

void set_num_threads(int threads) {
  std::lock_guard<std::mutex> lock(pool_mutex);
  requested_threads = std::max(0, threads);
  const int wanted = requested_threads > 0 ? requested_threads : int(std::max(1u, std::thread::hardware_concurrency()));
  if (pool && pool->size() != wanted) pool.reset();
}

int num_threads() {
  return requested_threads > 0 ? requested_threads : std::max(1u, std::thread::hardware_concurrency());
}

void parallel_for(int64_t begin, int64_t end, const std::function<void(int64_t, int64_t)>& body, int64_t grain) {
  if (end <= begin) return;
  grain = std::max<int64_t>(1, grain);
  const int64_t n = end - begin;
  const int threads = num_threads();
  if (in_worker || threads == 1 || n <= grain) {
    body(begin, end);
    return;
  }
  // A few chunks per thread balance uneven work without much scheduling overhead.
  const int64_t chunks = std::min<int64_t>((n + grain - 1) / grain, int64_t(threads) * 4);
  const int64_t chunk = (n + chunks - 1) / chunks;

  auto the_pool = get_pool();
  std::mutex done_mutex;
  std::condition_variable done_cv;
  int64_t remaining = chunks;
  std::exception_ptr first_error;
  std::atomic<bool> failed{false};
  for (int64_t c = 0; c < chunks; ++c) {
    const int64_t b = begin + c * chunk, e = std::min(end, b + chunk);
    the_pool->submit([&, b, e] {
      if (!failed.load() && b < e) {
        try {
          body(b, e);
        } catch (...) {
          std::lock_guard<std::mutex> lock(done_mutex);
          if (!first_error) first_error = std::current_exception();
          failed = true;
        }
      }
      std::lock_guard<std::mutex> lock(done_mutex);
      if (--remaining == 0) done_cv.notify_one();
    });
  }
  std::unique_lock<std::mutex> lock(done_mutex);
  done_cv.wait(lock, [&] { return remaining == 0; });
  if (first_error) std::rethrow_exception(first_error);
}

void keep_freed_memory() {
  mallopt(M_MMAP_MAX, 0);         // large blocks from the heap too, not from fresh mappings
  mallopt(M_TRIM_THRESHOLD, -1);  // and the heap is never trimmed
  mallopt(M_ARENA_MAX, 1);        // one heap for all threads, so that each thread reuses the pages others freed
  // The heap grown by ~2 GB of address space at once (the pad above one such block), and that range handed to
  // transparent huge pages: a fresh 2 MB of it then costs one page fault instead of 512. Nothing is committed until
  // touched. Where the kernel refuses the range or THP is off, the heap simply stays in small pages.
  constexpr size_t kPad = size_t(1) << 30;
  char* const start = static_cast<char*>(sbrk(0));
  mallopt(M_TOP_PAD, int(kPad));
  void* volatile block = malloc(kPad);  // volatile: the compiler may not drop the pair
  free(block);
  mallopt(M_TOP_PAD, 128 * 1024);  // mallopt(3)'s default again for any later growth
  char* const end = static_cast<char*>(sbrk(0));
  constexpr uintptr_t kHuge = uintptr_t(2) << 20;
  const uintptr_t from = (reinterpret_cast<uintptr_t>(start) + kHuge - 1) & ~(kHuge - 1);
  const uintptr_t to = reinterpret_cast<uintptr_t>(end) & ~(kHuge - 1);
  if (start != reinterpret_cast<char*>(-1) && to > from) madvise(reinterpret_cast<void*>(from), to - from, MADV_HUGEPAGE);
}

}  // namespace bareskin
