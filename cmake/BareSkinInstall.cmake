# `make install` / `cmake --install build [--prefix DIR]`: the tool on PATH, found data relative to it
# (core/assets.h searches <prefix>/share/bareskin/{assets,template} beside <prefix>/bin/bareskin):
#   bin/bareskin and its command links (render, scan, uvtools), and bin/bareskin-torch where the Torch side is built
#     (bareskin hands it the commands that reach the Torch side: apps/CMakeLists.txt);
#   share/bareskin/assets: the setup assets `make deps` fetched, each folder with its licence (NOTICE / LICENSE);
#   share/bareskin/template: the default template face, built at install time by the installed binary from those
#     assets (BARESKIN_INSTALL_TEMPLATE_VERTICES, a cache variable or the environment at install time; default the
#     paper's size, 0 installs none);
#   share/bareskin/doc: README.md and docs/.
if(BARESKIN_TORCH_ONLY OR NOT TARGET bareskin)
  return()
endif()
set(BARESKIN_INSTALL_TEMPLATE_VERTICES 65000 CACHE STRING "Vertices of the template 'make install' builds (0: none)")

install(TARGETS bareskin RUNTIME DESTINATION bin)
if(TARGET bareskin-torch)
  install(TARGETS bareskin-torch RUNTIME DESTINATION bin)
endif()
foreach(alias render scan uvtools)
  install(CODE "execute_process(COMMAND \"${CMAKE_COMMAND}\" -E create_symlink bareskin
                \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/bin/${alias}\")")
endforeach()
# The assets without face-api's JavaScript bundle (the tests' oracle only).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/assets/ DESTINATION share/bareskin/assets OPTIONAL
        PATTERN dist EXCLUDE)
install(FILES ${PROJECT_SOURCE_DIR}/README.md DESTINATION share/bareskin/doc)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION share/bareskin/doc)
install(CODE "
  set(share \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/share/bareskin\")
  set(vertices ${BARESKIN_INSTALL_TEMPLATE_VERTICES})
  if(DEFINED ENV{BARESKIN_INSTALL_TEMPLATE_VERTICES})
    set(vertices \$ENV{BARESKIN_INSTALL_TEMPLATE_VERTICES})
  endif()
  if(NOT vertices GREATER 0)
    message(STATUS \"Template: none (BARESKIN_INSTALL_TEMPLATE_VERTICES 0)\")
  elseif(NOT EXISTS \"\${share}/assets/mediapipe_face_mesh\")
    message(WARNING \"No assets were installed (run 'make deps' first): no default template\")
  else()
    message(STATUS \"Building the default template (\${vertices} vertices): \${share}/template\")
    execute_process(COMMAND \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/bin/bareskin\" template -q
                            --vertices \${vertices} --assets \"\${share}/assets\"
                            -o \"\${share}/template\"
                    RESULT_VARIABLE result)
    if(NOT result EQUAL 0)
      message(FATAL_ERROR \"bareskin template failed (\${result})\")
    endif()
  endif()
")
