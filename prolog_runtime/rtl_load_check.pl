:- module(rtl_load_check, [rtl_load_check/2]).

/** <module> Loading a compiled program to see whether it loads (`retalisc check`)

`retalisc check` loads the compiled program of a program that loads other files (an
`ensure_loaded/1`, `use_module/1`, `consult/1`, ... directive: which files exist and what
they define only SWI-Prolog knows) with

    swipl -g "rtl_load_check:rtl_load_check(TextFile, Id)" -t halt PROLOG_RUNTIME/rtl_load_check.pl

and reports each error SWI-Prolog prints while loading it as an error of the program. The
program (trusted: it is the program being checked) is read from TextFile as if it were the
file Id, so that relative file names in its directives are found where they would be when
it is compiled next to its source.
*/

:- dynamic loading/1.

%!  rtl_load_check(+TextFile, +Id) is det.
%
%   Load the program text in TextFile as the file Id (with `retalis_embedded` set, so that
%   the program does not run) and write one line `LINE<TAB>TEXT` to standard output for
%   each error printed while it loads (LINE 0 when the message names no line of Id), in
%   place of SWI-Prolog's message.

rtl_load_check(TextFile, Id) :-
    create_prolog_flag(retalis_embedded, true, []),
    setup_call_cleanup(
        ( asserta(loading(Id)),
          open(TextFile, read, In, [encoding(utf8)]),
          set_stream(In, file_name(Id)) ),
        catch(load_files(Id, [stream(In)]), Error, print_message(error, Error)),
        ( close(In), retractall(loading(_)) )).

:- multifile user:message_hook/3.

user:message_hook(_, Kind, Lines) :-
    loading(Id),
    Kind == error,
    (   source_location(File, Line), File == Id
    ->  true
    ;   Line = 0
    ),
    with_output_to(string(Text), print_message_lines(current_output, '', Lines)),
    split_string(Text, "\n", " \t", Parts0),
    exclude(==(""), Parts0, Parts),
    atomic_list_concat(Parts, ' ', OneLine),
    format(user_output, "~w\t~w~n", [Line, OneLine]).
