/*  Support of the plunit tests that need a compiled program (not a test file itself): the
    program text compiled by `python -m retalisc compile` and loaded as the Python driver
    loads one (flag `retalis_embedded`: rtl_main/0 does nothing). The Python is
    `$RETALISC_PYTHON` or `python3`, run in the repository with it on PYTHONPATH
    (tests/test_plunit.py sets both):

        RETALISC_PYTHON=.venv/bin/python swipl -g run_tests -t halt prolog_runtime/tests/test_policy.pl
*/
:- module(compiled_program, [load_compiled_program/3]).
:- use_module(library(process)).
:- use_module(library(readutil)).

%!  load_compiled_program(+Name, +Source:string, -Module) is det.
%
%   Compile Source (a .rtl program, the test's own constant text) and load it; Module is
%   the program's module.

load_compiled_program(Name, Source, Module) :-
    (   current_prolog_flag(retalis_embedded, _)
    ->  set_prolog_flag(retalis_embedded, true)
    ;   create_prolog_flag(retalis_embedded, true, [])
    ),
    tmp_file(Name, Base),
    file_name_extension(Base, rtl, Rtl),
    file_name_extension(Base, pl, Pl),
    setup_call_cleanup(open(Rtl, write, Out, [encoding(utf8)]), write(Out, Source), close(Out)),
    module_property(compiled_program, file(Here)),
    file_directory_name(Here, Tests),
    file_directory_name(Tests, Runtime),
    file_directory_name(Runtime, Root),
    (   user:file_search_path(retalis_runtime, _) -> true ; assertz(user:file_search_path(retalis_runtime, Runtime)) ),
    (   getenv('RETALISC_PYTHON', Python0), Python0 \== '' -> Python = Python0 ; Python = path(python3) ),
    (   getenv('PYTHONPATH', Path0) -> atomic_list_concat([Root, Path0], ':', Path) ; Path = Root ),
    process_create(Python, ['-m', retalisc, compile, Rtl, '-o', Pl],
                   [cwd(Root), environment(['PYTHONPATH'=Path]), stderr(pipe(Err)), process(Pid)]),
    read_string(Err, _, Errors), close(Err),
    process_wait(Pid, Status),
    delete_file(Rtl),
    (   Status == exit(0)
    ->  true
    ;   throw(error(compile_failed(Name, Status, Errors), _))
    ),
    load_files(Pl, []),
    source_file_property(Pl, module(Module)).
