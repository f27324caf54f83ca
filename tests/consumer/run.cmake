# ctest's install_consumer: installs the built slamkit into a fresh prefix, then configures, builds
# and runs tests/consumer against it. Arguments: -DBUILD_DIR=<slamkit build> -DWORK=<scratch folder>
# -DCXX_COMPILER=<compiler> -DCXX_FLAGS=<flags>: the consumer is built as slamkit was (a static library
# built with sanitizers needs them at the consumer's link too).
file(REMOVE_RECURSE ${WORK})
function(step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}")
  endif()
endfunction()
step(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK}/prefix)
step(${CMAKE_COMMAND} -S ${CMAKE_CURRENT_LIST_DIR} -B ${WORK}/build -DCMAKE_BUILD_TYPE=Release
     -DCMAKE_PREFIX_PATH=${WORK}/prefix -DCMAKE_CXX_COMPILER=${CXX_COMPILER} "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}")
step(${CMAKE_COMMAND} --build ${WORK}/build)
step(${WORK}/build/consumer)
step(${WORK}/prefix/bin/slamkit --version)
# What `slamkit run --help` and the documentation point to.
foreach(file share/slamkit/config/victoria-park.json share/slamkit/config/association-cluttered.json
             share/doc/slamkit/README.md share/doc/slamkit/choosing.md share/doc/slamkit/architecture.md)
  if(NOT EXISTS ${WORK}/prefix/${file})
    message(FATAL_ERROR "not installed: ${file}")
  endif()
endforeach()
