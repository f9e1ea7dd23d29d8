# Every dependency comes from a Debian package (CPU machine) or, for BARESKIN_TORCH_ONLY, from what the GPU machine has
# (pip torch's LibTorch, Eigen, nlohmann-json, CLI11, GTest, and spdlog/fmt headers carried in .gpu-vendor/).
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(nlohmann_json 3.9 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(Threads REQUIRED)
# PNG in memory (core/png.h: the shard codec) and tar (dataset shards): both present on the GPU machine too (libarchive's
# headers travel in .gpu-vendor/ there; the library is a dependency of its CMake).
find_package(ZLIB REQUIRED)
find_package(PNG REQUIRED)
if(BARESKIN_TORCH_ONLY)
  # The GPU machine has the runtime library only (a dependency of its CMake) and the headers from .gpu-vendor/.
  find_library(LibArchive_LIBRARY NAMES archive libarchive.so.13)
endif()
find_package(LibArchive REQUIRED)

if(BARESKIN_TORCH_ONLY)
  # Header-only spdlog + fmt: the GPU machine has no compiled spdlog/fmt.
  find_path(SPDLOG_INCLUDE_DIR spdlog/spdlog.h REQUIRED)
  find_path(FMT_INCLUDE_DIR fmt/format.h REQUIRED)
  add_library(bareskin_spdlog INTERFACE)
  target_include_directories(bareskin_spdlog SYSTEM INTERFACE ${SPDLOG_INCLUDE_DIR} ${FMT_INCLUDE_DIR})
  target_compile_definitions(bareskin_spdlog INTERFACE SPDLOG_HEADER_ONLY FMT_HEADER_ONLY SPDLOG_FMT_EXTERNAL)
else()
  find_package(spdlog REQUIRED)
  add_library(bareskin_spdlog INTERFACE)
  target_link_libraries(bareskin_spdlog INTERFACE spdlog::spdlog)

  find_package(OpenMesh REQUIRED)
  find_package(CGAL REQUIRED)
  find_package(OpenEXR REQUIRED)
  find_package(OpenImageIO REQUIRED)
  # Debian's OpenImageIO config lists /usr/include/opencv4 (absent unless OpenCV is installed): drop it (docs/environment.md).
  get_target_property(_oiio_inc OpenImageIO::OpenImageIO INTERFACE_INCLUDE_DIRECTORIES)
  if(_oiio_inc)
    list(FILTER _oiio_inc EXCLUDE REGEX "opencv4")
    set_target_properties(OpenImageIO::OpenImageIO PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_oiio_inc}")
  endif()
  find_package(Spectra REQUIRED)
  # CHOLMOD (SuiteSparse) for the NICP normal equations: supernodal Cholesky, symbolic analysis reused.
  find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse REQUIRED)
  find_library(CHOLMOD_LIBRARY cholmod REQUIRED)
  add_library(bareskin_cholmod INTERFACE)
  target_include_directories(bareskin_cholmod SYSTEM INTERFACE ${CHOLMOD_INCLUDE_DIR})
  target_link_libraries(bareskin_cholmod INTERFACE ${CHOLMOD_LIBRARY})
  find_package(Ceres REQUIRED)
  find_program(COLMAP_EXECUTABLE colmap)
  if(NOT COLMAP_EXECUTABLE)
    message(WARNING "colmap executable not found (Debian package 'colmap'); run 'make deps'")
  endif()
endif()

if(BARESKIN_WITH_TORCH OR BARESKIN_TORCH_ONLY)
  # Any LibTorch (BARESKIN_TORCH, Torch_DIR or the default): version, CUDA and C++ ABI printed, a foreign ABI refused.
  include(${CMAKE_CURRENT_LIST_DIR}/BareSkinTorch.cmake)
endif()

if(BARESKIN_TESTS)
  find_package(GTest REQUIRED)
endif()
