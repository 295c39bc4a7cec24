# ctest pipeline_benchmark_smoke: runs the pipeline benchmark at 160x106 and
# checks that its table and JSON are well formed and agree (never the timings).
#   cmake -DBENCHMARK=<pipeline_benchmark> -DSCANBENCH=<scanbench> -DWORK_DIR=<scratch> -P pipeline_benchmark_check.cmake
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")
set(json_file "${WORK_DIR}/pipeline.json")
execute_process(
  COMMAND "${BENCHMARK}" --width 160 --height 106 --json "${json_file}" --work-dir "${WORK_DIR}"
  RESULT_VARIABLE rc OUTPUT_VARIABLE table ERROR_VARIABLE log)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "pipeline_benchmark exited with ${rc}:\n${log}")
endif()
message(STATUS "table:\n${table}")

# The table: a header naming size, LEDs and threads, then one row per figure.
set(number "[0-9]+\\.[0-9]+")
foreach(row
    "^Pipeline at 160x106, 10 LEDs, 11 frames \\([0-9.]+ MB\\), 2 threads; session simulated in this run"
    "\nLoad average at the start ${number}, at the end ${number} \\(1 min\\), on [0-9]+ CPUs\n"
    "\nfigure +seconds +x floor +peak RSS +target +met\n"
    "\nfloor: LibRaw unpack of 11 frames +${number} +${number} GB"
    "\nfloor: write ${number} MB \\(fsynced\\) +${number} +${number} GB"
    "\nfloor +${number} +1\\.00"
    "\nsolve \\([a-z_]+\\) +${number} +${number} +${number} GB +<= 2\\.0x, <= 1\\.00 GB +(yes|no)\n"
    "\n  write_maps +${number}\n"
    "\n  result folder ${number} MB +<= 200\\.0 MB +(yes|no)\n"
    "\nexport \\(png16\\) +${number} +${number} +${number} GB +<= 4\\.0x, <= 1\\.50 GB +(yes|no)\n"
    "\ncapture-to-result \\(sequential\\) +${number} +${number} +${number} GB +<= 3\\.0 s +(yes|no)\n"
    "\ncapture-to-result \\(solve-while-capture\\) +${number} +${number} +${number} GB +<= 3\\.0 s +(yes|no)\n"
    "\n  capture of 11 frames +${number}")
  if(NOT table MATCHES "${row}")
    message(FATAL_ERROR "table has no row matching '${row}'")
  endif()
endforeach()

# The JSON: every figure present, positive where it must be, and its ratio the
# figure over the floor.
file(READ "${json_file}" report)
string(JSON schema GET "${report}" schema)
if(NOT schema STREQUAL "scanbench.pipeline_benchmark")
  message(FATAL_ERROR "JSON schema is '${schema}'")
endif()
foreach(key width height leds frames threads cpus)
  string(JSON value GET "${report}" ${key})
  if(NOT value MATCHES "^[1-9][0-9]*$")
    message(FATAL_ERROR "JSON ${key} is '${value}', not a positive integer")
  endif()
endforeach()
string(JSON width GET "${report}" width)
string(JSON frames GET "${report}" frames)
if(NOT width EQUAL 160 OR NOT frames EQUAL 11)
  message(FATAL_ERROR "JSON width ${width} frames ${frames}: expected 160 and 11")
endif()
string(JSON floor GET "${report}" floor seconds)
string(JSON decode GET "${report}" floor decode seconds)
string(JSON write GET "${report}" floor write seconds)
string(JSON written GET "${report}" floor write bytes)
string(JSON result_bytes GET "${report}" solve bytes_written)
if(NOT floor GREATER 0 OR NOT written EQUAL result_bytes)
  message(FATAL_ERROR "floor ${floor} s (decode ${decode}, write ${write}); wrote ${written} bytes for a "
                      "result of ${result_bytes}")
endif()
foreach(stage solve export latency latency_sequential)
  string(JSON seconds GET "${report}" ${stage} seconds)
  string(JSON ratio GET "${report}" ${stage} ratio_to_floor)
  string(JSON rss GET "${report}" ${stage} peak_rss_bytes)
  string(JSON met GET "${report}" ${stage} target_met)
  string(JSON targets LENGTH "${report}" ${stage} target)
  if(NOT seconds GREATER 0 OR NOT rss GREATER 1000000 OR targets LESS 1 OR NOT met MATCHES "^(ON|OFF)$")
    message(FATAL_ERROR "${stage}: seconds ${seconds}, peak RSS ${rss}, ${targets} targets, met '${met}'")
  endif()
  # CMake's math is integer only: ratio x floor against the figure, each in
  # millionths (a number JSON writes with an exponent is skipped).
  foreach(name seconds ratio floor)
    string(REGEX MATCH "^([0-9]+)(\\.([0-9]*))?(e-?[0-9]+)?$" ok "${${name}}")
    if(NOT ok OR CMAKE_MATCH_4)
      set(micro_${name} "")
    else()
      string(SUBSTRING "${CMAKE_MATCH_3}000000" 0 6 fraction)
      math(EXPR micro_${name} "${CMAKE_MATCH_1} * 1000000 + 1${fraction} - 1000000")
    endif()
  endforeach()
  if(micro_seconds AND micro_ratio AND micro_floor)
    math(EXPR product "${micro_ratio} * ${micro_floor} / 1000000")
    math(EXPR diff "${product} - ${micro_seconds}")
    math(EXPR tolerance "${micro_seconds} / 1000 + 100")
    if(diff LESS -${tolerance} OR diff GREATER ${tolerance})
      message(FATAL_ERROR "${stage}: ratio ${ratio} x floor ${floor} = ${product} us, not its ${seconds} s")
    endif()
  endif()
endforeach()
string(JSON mode GET "${report}" latency mode)
if(NOT mode MATCHES "^(sequential|solve-while-capture)$")
  message(FATAL_ERROR "latency mode '${mode}'")
endif()
string(JSON stages LENGTH "${report}" solve stages)
if(stages LESS 3)
  message(FATAL_ERROR "solve lists ${stages} stage times")
endif()

foreach(stage latency latency_sequential)
  string(JSON cpu GET "${report}" ${stage} cpu_seconds_after_last_frame)
  string(JSON solve_stages LENGTH "${report}" ${stage} solve_stages)
  string(JSON rss GET "${report}" ${stage} rss_at_last_frame_bytes)
  if(NOT cpu GREATER 0 OR solve_stages LESS 3 OR NOT rss GREATER 1000000)
    message(FATAL_ERROR "${stage}: CPU after the last frame '${cpu}' s, ${solve_stages} solve stage times")
  endif()
endforeach()
if(NOT table MATCHES "\n  CPU after the last frame \\(s\\): ${number}\n")
  message(FATAL_ERROR "table has no 'CPU after the last frame' row")
endif()

# Nothing left behind but the JSON: the temporary folder is removed.
file(GLOB left "${WORK_DIR}/pipeline_benchmark.*")
if(left)
  message(FATAL_ERROR "temporary folder left behind: ${left}")
endif()

# --latency-only: the two capture-to-result rows alone, without a ratio to a floor it did not measure
# (with --develop-ahead: the live row's decoder develops frames; how many depends on the load).
set(latency_json "${WORK_DIR}/latency.json")
execute_process(
  COMMAND "${BENCHMARK}" --latency-only --develop-ahead --width 160 --height 106 --json "${latency_json}"
          --work-dir "${WORK_DIR}"
  RESULT_VARIABLE rc OUTPUT_VARIABLE table ERROR_VARIABLE log)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "pipeline_benchmark --latency-only exited with ${rc}:\n${log}")
endif()
foreach(row
    "^Capture-to-result at 160x106, 2 threads \\(no floor, solve or export: --latency-only\\)\n"
    "\ncapture-to-result \\(sequential\\) +${number} +${number} GB +<= 3\\.0 s +(yes|no)\n"
    "\ncapture-to-result \\(solve-while-capture\\) +${number} +${number} GB +<= 3\\.0 s +(yes|no)\n")
  if(NOT table MATCHES "${row}")
    message(FATAL_ERROR "--latency-only table has no row matching '${row}':\n${table}")
  endif()
endforeach()
if(table MATCHES "\n(floor[: ]|solve \\(|export \\()")
  message(FATAL_ERROR "--latency-only ran more than the latency:\n${table}")
endif()
file(READ "${latency_json}" report)
foreach(stage latency latency_sequential)
  string(JSON seconds GET "${report}" ${stage} seconds)
  string(JSON cpu GET "${report}" ${stage} cpu_seconds_after_last_frame)
  string(JSON ratio TYPE "${report}" ${stage} ratio_to_floor)
  if(NOT seconds GREATER 0 OR NOT cpu GREATER 0 OR NOT ratio STREQUAL "NULL")
    message(FATAL_ERROR "--latency-only ${stage}: seconds '${seconds}', CPU '${cpu}', ratio type ${ratio}")
  endif()
endforeach()
string(JSON developed GET "${report}" latency frames_developed_live)
if(NOT developed MATCHES "^([0-9]|10)$")
  message(FATAL_ERROR "--latency-only --develop-ahead: frames_developed_live '${developed}'")
endif()

# A reused session (--session): named in the header, and what the run added
# to it (its result and export; exports/, which it made) is gone afterwards.
set(session "${WORK_DIR}/reused")
execute_process(COMMAND "${SCANBENCH}" simulate "${session}" --width 160 --height 106
  RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE log)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "scanbench simulate exited with ${rc}:\n${log}")
endif()
execute_process(
  COMMAND "${BENCHMARK}" --session "${session}" --work-dir "${WORK_DIR}"
  RESULT_VARIABLE rc OUTPUT_VARIABLE table ERROR_VARIABLE log)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "pipeline_benchmark --session exited with ${rc}:\n${log}")
endif()
if(NOT table MATCHES "^Pipeline at 160x106, 10 LEDs, 11 frames \\([0-9.]+ MB\\), 2 threads; session reused: ")
  message(FATAL_ERROR "the --session run's header does not say the session was reused:\n${table}")
endif()
foreach(added results exports)
  file(GLOB left "${session}/${added}/*")
  if(left)
    message(FATAL_ERROR "the --session run left ${left} behind")
  endif()
endforeach()
if(EXISTS "${session}/exports")
  message(FATAL_ERROR "the --session run left ${session}/exports (it made it) behind")
endif()
if(NOT EXISTS "${session}/session.json")
  message(FATAL_ERROR "the --session run removed ${session}/session.json")
endif()
file(REMOVE_RECURSE "${WORK_DIR}")
