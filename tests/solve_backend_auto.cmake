# --backend auto without a GPU (the test hides any: CUDA_VISIBLE_DEVICES=-1)
# solves on the CPU: the same radiosity file, byte for byte, as --backend
# cpu, and the stats and the log say cpu.
#   cmake -DSOLVE=path -DDIR=solve_data -P solve_backend_auto.cmake
foreach(input good.ff open_box.ff furnace_09.ff)
  foreach(method cg jacobi)
    set(tag ${input}_${method})
    file(REMOVE ${DIR}/auto_${tag}.rad ${DIR}/cpu_${tag}.rad ${DIR}/auto_${tag}.json)
    execute_process(COMMAND ${SOLVE} --backend auto --method ${method} --stats auto_${tag}.json
                            -o auto_${tag}.rad ${input}
                    WORKING_DIRECTORY ${DIR} RESULT_VARIABLE code_auto OUTPUT_VARIABLE out ERROR_VARIABLE log)
    execute_process(COMMAND ${SOLVE} --backend cpu --method ${method} -o cpu_${tag}.rad ${input}
                    WORKING_DIRECTORY ${DIR} RESULT_VARIABLE code_cpu)
    if(NOT code_auto EQUAL 0 OR NOT code_cpu EQUAL 0)
      message(FATAL_ERROR "${tag}: exit codes auto ${code_auto}, cpu ${code_cpu}\n${log}")
    endif()
    execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${DIR}/auto_${tag}.rad ${DIR}/cpu_${tag}.rad
                    RESULT_VARIABLE differ)
    if(differ)
      message(FATAL_ERROR "${tag}: --backend auto wrote other bits than --backend cpu")
    endif()
    file(READ ${DIR}/auto_${tag}.json stats)
    if(NOT stats MATCHES "\"backend\": \"cpu\"")
      message(FATAL_ERROR "${tag}: the stats do not say backend cpu")
    endif()
    if(NOT log MATCHES ", backend cpu")
      message(FATAL_ERROR "${tag}: the log does not say backend cpu:\n${log}")
    endif()
    message(STATUS "${tag}: auto = cpu, bit for bit")
  endforeach()
endforeach()
