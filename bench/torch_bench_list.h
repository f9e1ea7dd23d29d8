// The programs of bench/torch_bench.cc: BARESKIN_BENCH(name, namespace of its main) for each one this build has
// (bench/CMakeLists.txt defines BARESKIN_BENCH_<NAME> for them). No include guard: read once per expansion.
#ifdef BARESKIN_BENCH_RENDER_TORCH
BARESKIN_BENCH(render_torch_bench, bareskin_bench_render_torch)
#endif
#ifdef BARESKIN_BENCH_DETECT
BARESKIN_BENCH(detect_bench, bareskin_bench_detect)
#endif
#ifdef BARESKIN_BENCH_LOSSES
BARESKIN_BENCH(losses_bench, bareskin_bench_losses)
#endif
#ifdef BARESKIN_BENCH_TRAINING
BARESKIN_BENCH(training_bench, bareskin_bench_training)
#endif
#ifdef BARESKIN_BENCH_FIT_SOLVER
BARESKIN_BENCH(fit_solver_bench, bareskin_bench_fit_solver)
#endif
#ifdef BARESKIN_BENCH_NETS
BARESKIN_BENCH(nets_bench, bareskin_bench_nets)
#endif
#ifdef BARESKIN_BENCH_TRAIN_STEP
BARESKIN_BENCH(train_step_bench, bareskin_bench_train_step)
#endif
