# Which LibTorch the Torch side builds against, and whether it can link here (docs/gpu.md).
#
# BARESKIN_TORCH (`make build TORCH=…`) names one: the unzipped libtorch/ folder of a pytorch.org download, a Python
# torch package folder (pip's ships its CMake files), `python` (the torch that python3 imports), or the folder holding
# TorchConfig.cmake. Without it, -DTorch_DIR=… or CMake's default search (Debian's libtorch-dev) decides.
# Configure prints the version, CUDA or CPU only, and the C++ ABI, and refuses a LibTorch whose ABI differs from the
# system's C++ libraries (Debian's use the cxx11 ABI): its std::string symbols would not link with them.
set(BARESKIN_TORCH "" CACHE STRING
  "LibTorch to build against: libtorch/ folder, Python torch package folder, 'python', or the folder of TorchConfig.cmake")

# The one line a refusal prints (a leading space keeps CMake from re-flowing it): what is wrong, then which download.
set(_bareskin_torch_download "take the cxx11-ABI LibTorch zip (https://pytorch.org/get-started/locally: LibTorch, \
C++/Java, a CUDA one for a GPU) and run make build TORCH=/path/to/libtorch")

if(BARESKIN_TORCH)
  set(_where "${BARESKIN_TORCH}")
  if(_where STREQUAL "python")
    execute_process(COMMAND python3 -c "import os, torch; print(os.path.dirname(torch.__file__))"
      OUTPUT_VARIABLE _where OUTPUT_STRIP_TRAILING_WHITESPACE RESULT_VARIABLE _rc ERROR_QUIET)
    if(NOT _rc EQUAL 0)
      message(FATAL_ERROR " TORCH=python: python3 cannot import torch; install torch for python3 (pip) or ${_bareskin_torch_download}")
    endif()
  endif()
  get_filename_component(_where "${_where}" ABSOLUTE)
  set(_config_dir "")
  foreach(_d "${_where}" "${_where}/share/cmake/Torch" "${_where}/lib/cmake/Torch"
             "${_where}/lib/${CMAKE_LIBRARY_ARCHITECTURE}/cmake/Torch")
    if(EXISTS "${_d}/TorchConfig.cmake")
      set(_config_dir "${_d}")
      break()
    endif()
  endforeach()
  if(NOT _config_dir)
    set(_why "")
    if(EXISTS "${_where}/__init__.py")
      set(_why " (a Python torch without CMake files: Debian's python3-torch has them in libtorch-dev, the default)")
    endif()
    message(FATAL_ERROR " TORCH=${BARESKIN_TORCH}: no TorchConfig.cmake in ${_where}, share/cmake/Torch or lib/cmake/Torch${_why}; ${_bareskin_torch_download}")
  endif()
  if(NOT "${Torch_DIR}" STREQUAL "${_config_dir}")
    # Another LibTorch than the cached one: forget what the previous one's configuration found.
    foreach(_v Caffe2_DIR c10_LIBRARY TORCH_LIBRARY C10_CUDA_LIBRARY kineto_LIBRARY)
      unset(${_v} CACHE)
    endforeach()
  endif()
  set(Torch_DIR "${_config_dir}" CACHE PATH "The folder of TorchConfig.cmake (set from BARESKIN_TORCH)" FORCE)
elseif(Torch_DIR AND NOT EXISTS "${Torch_DIR}/TorchConfig.cmake" AND NOT Torch_DIR MATCHES "NOTFOUND$")
  message(FATAL_ERROR " Torch_DIR=${Torch_DIR}: no TorchConfig.cmake there; ${_bareskin_torch_download}")
endif()

# TorchConfig.cmake searches the system's folders before its own for Caffe2 (which defines the torch and c10 targets)
# and for libc10 and libtorch, so with libtorch-dev installed a downloaded LibTorch would link Debian's libraries under
# its own headers. Its own Caffe2 first; after the search, its own libraries instead of any from elsewhere.
if(Torch_DIR AND EXISTS "${Torch_DIR}/../Caffe2/Caffe2Config.cmake")
  get_filename_component(_caffe2 "${Torch_DIR}/../Caffe2" ABSOLUTE)
  set(Caffe2_DIR "${_caffe2}" CACHE PATH "The folder of Caffe2Config.cmake (beside Torch_DIR)" FORCE)
endif()
find_package(Torch REQUIRED)
foreach(_pair c10_LIBRARY:c10 TORCH_LIBRARY:torch)
  string(REPLACE ":" ";" _pair "${_pair}")
  list(GET _pair 0 _var)
  list(GET _pair 1 _lib)
  string(FIND "${${_var}}" "${TORCH_INSTALL_PREFIX}/" _at)
  if(${_var} AND TORCH_INSTALL_PREFIX AND NOT _at EQUAL 0)
    set(_foreign "${${_var}}")
    unset(${_var} CACHE)
    find_library(${_var} ${_lib} NO_DEFAULT_PATH
      PATHS "${TORCH_INSTALL_PREFIX}/lib" "${TORCH_INSTALL_PREFIX}/lib/${CMAKE_LIBRARY_ARCHITECTURE}")
    if(NOT ${_var})
      message(FATAL_ERROR " LibTorch at ${TORCH_INSTALL_PREFIX} has no lib${_lib} under lib/ (the system's ${_foreign} cannot go with it); ${_bareskin_torch_download}")
    endif()
    list(FIND TORCH_LIBRARIES "${_foreign}" _i)
    if(_i GREATER -1)
      list(REMOVE_AT TORCH_LIBRARIES ${_i})
      list(INSERT TORCH_LIBRARIES ${_i} "${${_var}}")
    endif()
  endif()
endforeach()

# An installed bareskin finds a LibTorch outside the system's folders (a download) where it was linked from.
set(CMAKE_INSTALL_RPATH_USE_LINK_PATH ON)

# CUDA or CPU only.
if(CAFFE2_USE_CUDA OR TARGET torch_cuda OR TARGET c10_cuda)
  set(_cuda "with CUDA")
  foreach(_v CUDAToolkit_VERSION CUDA_VERSION)
    if(${_v})
      set(_cuda "with CUDA ${${_v}}")
      break()
    endif()
  endforeach()
  set(BARESKIN_TORCH_CUDA ON)
else()
  set(_cuda "CPU only")
  set(BARESKIN_TORCH_CUDA OFF)
endif()

# The system's C++ ABI: what the compiler uses by default, as every C++ library of the distribution was built with it.
include(CheckCXXSourceCompiles)
check_cxx_source_compiles("#include <string>
#ifndef __GLIBCXX__
#error not libstdc++
#endif
int main() { return 0; }" BARESKIN_LIBSTDCXX)
check_cxx_source_compiles("#include <string>
#if !_GLIBCXX_USE_CXX11_ABI
#error pre-cxx11 ABI
#endif
int main() { return 0; }" BARESKIN_LIBSTDCXX_CXX11_ABI)
if(BARESKIN_LIBSTDCXX_CXX11_ABI)
  set(_system_abi 1)
else()
  set(_system_abi 0)
endif()

# LibTorch's ABI: from the flag its configuration hands on, or, where it hands none, by linking a call that passes a
# std::string into libc10 with the system's ABI: the link fails exactly when the ABIs differ.
set(_torch_abi "")
set(_abi_from "TORCH_CXX_FLAGS")
if(TORCH_CXX_FLAGS MATCHES "_GLIBCXX_USE_CXX11_ABI=([01])")
  set(_torch_abi ${CMAKE_MATCH_1})
elseif(BARESKIN_LIBSTDCXX AND (c10_LIBRARY OR TARGET c10))
  # c10::detail::torchCheckFail(…, const std::string&) is exported by every LibTorch since 1.8; declared here rather
  # than through c10's headers, so the check compiles in a moment.
  set(_abi_from "link check")
  set(_probe "${CMAKE_BINARY_DIR}/CMakeFiles/bareskin_torch_abi")
  file(WRITE "${_probe}/abi.cc" "#include <cstdint>
#include <string>
namespace c10 { namespace detail {
[[noreturn]] void torchCheckFail(const char*, const char*, std::uint32_t, const std::string&);
} }
int main(int argc, char**) {
  if (argc > 99) c10::detail::torchCheckFail(\"\", \"\", 0, std::string(\"abi\"));
  return 0;
}
")
  if(c10_LIBRARY)
    set(_c10 "${c10_LIBRARY}")
  else()
    set(_c10 c10)
  endif()
  unset(_links CACHE)  # try_compile before CMake 3.25 keeps its result in the cache
  try_compile(_links "${_probe}/build" SOURCES "${_probe}/abi.cc" LINK_LIBRARIES "${_c10}"
    CXX_STANDARD 17 OUTPUT_VARIABLE _probe_log)
  if(_links)
    set(_torch_abi ${_system_abi})
  elseif(_probe_log MATCHES "undefined reference")
    if(_system_abi)
      set(_torch_abi 0)
    else()
      set(_torch_abi 1)
    endif()
  else()
    message(FATAL_ERROR " LibTorch at ${Torch_DIR}: a program using libc10 does not compile here (see ${_probe}); ${_bareskin_torch_download}")
  endif()
endif()

set(_abi_name_0 "pre-cxx11")
set(_abi_name_1 "cxx11")
if(NOT BARESKIN_LIBSTDCXX)
  message(STATUS "LibTorch ${Torch_VERSION}, ${_cuda}, C++ ABI not checked (not libstdc++): ${Torch_DIR}")
elseif(NOT _torch_abi STREQUAL _system_abi)
  if(NOT _system_abi)
    string(REPLACE "cxx11-ABI" "pre-cxx11-ABI" _bareskin_torch_download "${_bareskin_torch_download}")
  endif()
  message(FATAL_ERROR " LibTorch ${Torch_VERSION} (${Torch_DIR}) has the ${_abi_name_${_torch_abi}} C++ ABI (_GLIBCXX_USE_CXX11_ABI=${_torch_abi}, ${_abi_from}), this system's C++ libraries the ${_abi_name_${_system_abi}} one; ${_bareskin_torch_download}")
else()
  message(STATUS "LibTorch ${Torch_VERSION}, ${_cuda}, C++ ABI ${_abi_name_${_torch_abi}} (_GLIBCXX_USE_CXX11_ABI=${_torch_abi}, ${_abi_from}): ${Torch_DIR}")
endif()
