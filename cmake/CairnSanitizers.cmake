# The sanitizer builds (CAIRN_SANITIZE: 'address,undefined' or 'thread').
# Everything is instrumented. Product code keeps the preset's -O1, so the real-time and
# simulation tests run at a speed their bounds allow; code whose speed no test depends on
# (test bodies, the tools' command-line front ends) is built at -O0, which halves what the
# sanitizers cost the compiler there (CI's build time, not its checks: -O0 instruments the
# same memory accesses and races).
if(CAIRN_SANITIZE)
  add_compile_options(-fsanitize=${CAIRN_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_compile_definitions(CAIRN_SANITIZED=1)
  add_link_options(-fsanitize=${CAIRN_SANITIZE})
endif()

function(cairn_unoptimized_when_sanitized target)
  if(CAIRN_SANITIZE)
    target_compile_options(${target} PRIVATE -O0)
  endif()
endfunction()
