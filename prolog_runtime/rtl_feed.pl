:- module(rtl_feed,
          [ rtl_run_files/2,            % +Files, -Status
            rtl_run_jsonl_file/1,       % +File
            rtl_run_event_file/4,       % +File, +AllowControl, +Strict, -Outcome
            rtl_feed_lines/3,           % +Text, +FirstLineNo, -Output
            rtl_feed_lines/4,           % +Text, +FirstLineNo, +Options, -Output
            rtl_process_line/3,         % +Line, +Options, -Outcome
            rtl_summary/1,              % -Text
            rtl_summary/2,              % +Seconds, -Text
            rtl_end_of_input/2,         % +Mode, -Output
            rtl_heartbeat/2,            % +Time, -Output
            rtl_output_gone/1,          % @Error
            rtl_output_failed/2,        % @Error, -Why
            rtl_drop_output/0,
            rtl_stop_signal/2,          % ?Signal, ?Number
            error_text/2                % +Error, -Text
          ]).
:- use_module(library(apply)).
:- use_module(library(lists)).
:- use_module(rtl_ele).
:- use_module(rtl_io).
:- use_module(rtl_error_text, [rtl_error_text/2]).
:- use_module(rtl_lines, [rtl_read_line/3, rtl_split_lines/2, rtl_utf8_line/2, rtl_long_line/4]).
:- use_module(rtl_horizon).
:- use_module(rtl_time).
:- use_module(rtl_raise).
:- use_module(rtl_rules).
:- use_module(rtl_seen).
:- use_module(rtl_halt).
:- use_module(rtl_sync).
:- use_module(rtl_timers).
:- use_module(rtl_subscriptions).

/** <module> The line loops: event and control lines fed to the loaded program

Both roads of a run go through here: `swipl PROGRAM.pl FILE...` (retalis.pl's rtl_main/0
calls rtl_run_files/2) and the Python driver (rtl_api.pl calls rtl_feed_lines/4,
rtl_end_of_input/2, rtl_heartbeat/2 and rtl_summary/1). retalis.pl, the entry points of a
compiled program, re-exports what it exported before; this module imports neither it nor
rtl_api.pl, which both import it.
*/

%!  rtl_output_gone(@Error) is semidet.
%
%   Writing standard output failed because its reader went away
%   (`swipl OUT.pl FILE | head`). The run then ends at once with status 1, printing
%   nothing more (no summary), as `retalisc run` does when Python writes the output.

rtl_output_gone(error(io_error(write, user_output), context(_, 'Broken pipe'))).

%!  rtl_output_failed(@Error, -Why) is semidet.
%
%   Writing standard output failed otherwise (a full disk: `swipl OUT.pl FILE > /dev/full`).
%   The run ends with the line `retalis: cannot write standard output: Why`, the summary and
%   status 1.

rtl_output_failed(error(io_error(write, user_output), context(_, Why)), Why).

%!  rtl_drop_output is det.
%
%   What is left in standard output's buffer cannot be written: drop it.

rtl_drop_output :-
    catch(close(user_output, [force(true)]), _, true).

%!  rtl_stop_signal(?Signal, ?Number) is nondet.
%
%   The signals that stop a run (SIGTERM, SIGINT) with their numbers: the run ends as the
%   end of the input would, without the rest of the input, and the process with status
%   128 + Number (retalis.pl's rtl_main/0; rtl_run_event_file/4 for `retalisc run`).

rtl_stop_signal(term, 15).
rtl_stop_signal(int, 2).

%!  rtl_run_files(+Files:list, -Status:integer) is det.
%
%   The run of `swipl PROGRAM.pl FILE...`: the events raised while the program was loaded,
%   every line of each file in order (rtl_run_jsonl_file/1), then the end of the input.
%   Status is 0, or the status of rtl_stop/1 when the run was stopped.

rtl_run_files(Files, Status) :-
    catch(( startup_events,
            forall(member(File, Files), rtl_run_jsonl_file(File)),
            ( nb_current(rtl_drop_pending, true) -> Mode = drop ; Mode = run ),
            end_of_input(Mode, print_outcome(-)) ),
          rtl_stop(Status),
          true),
    (   var(Status) -> Status = 0 ; true ).

% The events raised while the program was loaded, processed before the first line.
startup_events :-
    catch(rtl_flush_raised, Error, true),
    (   var(Error)
    ->  true
    ;   rtl_drop_raised,
        event_failure(Error, "the events raised while loading", Outcome),
        print_outcome(-, 0, Outcome),
        stop_if_needed(Outcome)
    ).

%!  rtl_run_jsonl_file(+File) is det.
%
%   Process every line of an event file (`-` for standard input), writing the output to
%   standard output and the rejected and failed lines to standard error. Throws
%   `rtl_stop(1)` when the run must end (`--strict`, `halt` in program code).

rtl_run_jsonl_file(-) :- !,
    set_stream(user_input, encoding(iso_latin_1)),
    run_stream(user_input, '<stdin>').
rtl_run_jsonl_file(File) :-
    setup_call_cleanup(open(File, read, In, [encoding(iso_latin_1)]),
                       run_stream(In, File),
                       close(In)).

%!  rtl_run_event_file(+File:text, +AllowControl:text, +Strict:text, -Outcome:string) is det.
%
%   The loop of rtl_run_jsonl_file/1 (`swipl PROGRAM.pl FILE`) over the event file File
%   (`-`: standard input), for `retalisc run --events FILE` in the retalisc program itself
%   (retalisc/driver/run.py): each line is read, processed and its output written to
%   standard output here, flushed as soon as no more input is waiting, with no call from
%   Python per line; lines not processed and warnings go to standard error as `FILE:N: ...`
%   (`<stdin>:N: ...`). AllowControl and Strict are `true` or `false`. Outcome is `stopped`
%   when the run must end (`--strict`, `halt` in program code), `output gone` when standard
%   output's reader went away (rtl_output_gone/1), `signal N` when the signal N (SIGTERM,
%   SIGINT) stopped the run (the output written so far flushed, whole lines only; the caller
%   then ends the run with status 128 + N), `output failed: WHY` when standard output cannot
%   be written (a full disk), else `done`. Afterwards the output goes to the buffer again, as
%   an Engine wants it.

rtl_run_event_file(File0, AllowControl0, Strict0, Outcome) :-
    atom_string(File, File0),
    atom_string(AllowControl, AllowControl0),
    atom_string(Strict, Strict0),
    must_be(boolean, AllowControl),
    must_be(boolean, Strict),
    set_stream(user_output, encoding(utf8)),
    setup_call_cleanup(
        ( nb_setval(rtl_stream_options, [allow_control(AllowControl), strict(Strict)]),
          rtl_output_to(print),
          findall(Signal-Old, ( rtl_stop_signal(Signal, _), on_signal(Signal, Old, rtl_feed:signal_ends_loop) ),
                  Handlers) ),
        catch(( rtl_run_jsonl_file(File), flush_output(user_output), Outcome = "done" ),
              Stop,
              run_stopped(Stop, Outcome)),
        ( forall(member(Signal-Old, Handlers), on_signal(Signal, _, Old)),
          nb_setval(rtl_stop_signal, []),
          rtl_output_to(buffer),
          nb_setval(rtl_stream_options, []) )).

%   signal_ends_loop(+Signal): a stop signal during rtl_run_event_file/4 ends the loop
%   (rtl_signal(Number), which no event failure takes for its own: event_failure/3), also
%   when program code catches that: the loop looks at rtl_stop_signal after each line.

signal_ends_loop(Signal) :-
    rtl_stop_signal(Signal, Number),
    nb_setval(rtl_stop_signal, Number),
    throw(rtl_signal(Number)).

run_stopped(rtl_signal(Number), Outcome) :- !,
    catch(flush_output(user_output), _, true),
    format(string(Outcome), "signal ~w", [Number]).
run_stopped(rtl_stop(_), "stopped") :- !.
run_stopped(Error, "output gone") :- rtl_output_gone(Error), !.
run_stopped(Error, Outcome) :-
    rtl_output_failed(Error, Why),
    !,
    rtl_drop_output,
    format(string(Outcome), "output failed: ~w", [Why]).
run_stopped(Error, _) :- throw(Error).

% The input is read as bytes (ISO Latin-1) and each line cut and decoded as UTF-8 by
% rtl_read_line/3, as the Python driver's loops have the runtime cut and decode theirs
% (rtl_lines.pl, docs/runtime.md, "Event input"), each line at most max_line_bytes long.
run_stream(In, Name) :-
    stream_options(Options),
    read_line(In, Line0),
    without_bom(Line0, Line),
    with_output_buffer(In, with_action_output(run_lines(Line, In, Name, 1, Options))).

%   with_output_buffer(+In, :Goal): run Goal, which reads In, with standard output fully
%   buffered when In is a regular file: SWI-Prolog buffers user_output by line, which costs a
%   write(2) per output line. A live input (a pipe, a socket, a terminal) keeps the line
%   buffer, so that its output leaves as it is produced. The output is flushed afterwards,
%   and before anything is written to standard error (print_outcome/3, print_warnings/2).

with_output_buffer(In, Goal) :-
    (   stream_property(In, file_name(File)),
        exists_file(File),                      % a regular file (not a FIFO or a device)
        stream_property(user_output, buffer(Old)),
        Old \== full
    ->  setup_call_cleanup(set_stream(user_output, buffer(full)),
                           Goal,
                           ( flush_output(user_output), set_stream(user_output, buffer(Old)) ))
    ;   call(Goal)
    ).


stream_options(Options) :-
    (   nb_current(rtl_stream_options, Options0), Options0 \== []
    ->  Options = Options0
    ;   Options = []
    ).

% Each line read by read_line_to_string/2 (which waits for input) is followed by the lines
% already in the input buffer, read in blocks by the C reader (rtl_buffered_lines/3).
run_lines(end_of_file, _, _, _, _) :- !.
run_lines(Line, In, Name, N, Options) :-
    rtl_process_line(Line, Options, Outcome),
    line_done(Outcome, In, Name, N, Options),
    N1 is N + 1,
    run_buffered(In, Name, N1, Options, N2),
    read_line(In, Next),
    run_lines(Next, In, Name, N2, Options).

read_line(In, Line) :-
    rtl_flag(max_line_bytes, MaxBytes),
    rtl_read_line(In, MaxBytes, Line).

line_done(Outcome, In, Name, N, Options) :-
    (   Outcome == ok
    ->  print_warnings(Name, N)
    ;   print_outcome(Name, N, Outcome),
        print_warnings(Name, N),
        stop_if_needed(Outcome, Options)
    ),
    (   Name == '<stdin>' -> flush_if_idle(In) ; true ),
    (   nb_current(rtl_stop_signal, Number), integer(Number)   % one that program code caught
    ->  throw(rtl_signal(Number))
    ;   true
    ).

run_buffered(In, Name, N0, Options, N) :-
    rtl_flag(max_term_depth, MaxDepth),
    rtl_buffered_lines(In, MaxDepth, Items),
    (   Items == []
    ->  N = N0
    ;   run_items(Items, In, Name, N0, Options, N1),
        run_buffered(In, Name, N1, Options, N)
    ).

%   A run of event lines with a time "t" only (items a(Event, T)) is remembered for
%   retractions in one call (rtl_seen_add_atomic/1), then processed event by event. The run
%   ends before an event too far in the future (rtl_future_problem/2, for the clock as it
%   will be when the event's turn comes), which is then rejected on its own.

run_items([], _, _, N, _, N).
run_items([Item|Items], In, Name, N0, Options, N) :-
    (   Item = a(_, _),
        future_limit(Limit),
        atomic_run([Item|Items], Limit, Run, Rest),
        Run \== []
    ->  rtl_seen_add_atomic(Run),
        run_atomic(Run, Rest, In, Name, N0, Options, N1)
    ;   (   Item = a(Event, T)
        ->  rtl_process_parsed(event(add, Event, T, T), Options, Outcome)
        ;   Item = l(Line),
            rtl_process_line(Line, Options, Outcome)
        ),
        item_done(Outcome, Items, In, Name, N0, Options),
        N1 is N0 + 1,
        Rest = Items
    ),
    run_items(Rest, In, Name, N1, Options, N).

% The latest time an input event may end now (rtl_future_problem/2).
future_limit(Limit) :-
    rtl_flag(max_future, Max),
    (   Max == inf
    ->  Limit = inf
    ;   rtl_clock(Clock),
        get_time(Now),
        Limit is max(Clock, Now) + Max
    ).

atomic_run([Item|Items], Limit, Run, Rest) :-
    (   Item = a(_, T),
        T =< Limit
    ->  Run = [Item|Run1],
        (   Limit == inf -> Limit1 = inf
        ;   rtl_flag(max_future, Max), Limit1 is max(Limit, T + Max)
        ),
        atomic_run(Items, Limit1, Run1, Rest)
    ;   Run = [],
        Rest = [Item|Items]
    ).
atomic_run([], _, [], []).

%   The run is one block of input events (rtl_input_block/1): each event is processed by
%   rtl_block_input/3 under its own catch/3, with its own step limit, and reported as
%   run_event/5 reports it.

run_atomic(Run, Rest, In, Name, N0, Options, N) :-
    rtl_input_block(atomic_events(Run, Rest, In, Name, N0, Options, N)).

atomic_events([], _, _, _, N, _, N).
atomic_events([a(Event, T)|Run], Rest, In, Name, N0, Options, N) :-
    catch(rtl_block_input(Event, T, T), Error, true),
    (   var(Error)
    ->  (   Run \== []
        ->  (   rtl_warnings_pending -> print_warnings(Name, N0) ; true )
        ;   item_done(ok, Rest, In, Name, N0, Options)
        )
    ;   rtl_drop_raised,
        event_text(Event, Text),
        event_failure(Error, Text, Outcome),
        count_outcome(Outcome),
        (   Run == [] -> Items = Rest ; Items = Run ),
        item_done(Outcome, Items, In, Name, N0, Options)
    ),
    N1 is N0 + 1,
    atomic_events(Run, Rest, In, Name, N1, Options, N).

% The last item of a block may flush the output.
item_done(Outcome, Items, In, Name, N, Options) :-
    (   Outcome == ok, Items \== []
    ->  print_warnings(Name, N)
    ;   line_done(Outcome, In, Name, N, Options)
    ).

%   flush_if_idle(+In): on a live input (standard input: a pipe, a socket, a terminal), write
%   the output produced so far as soon as no more input is waiting, so that each event's
%   output leaves when it is processed; while input is waiting, output is batched.

flush_if_idle(In) :-
    (   catch(wait_for_input([In], Ready, 0), _, Ready = [])
    ->  true
    ;   Ready = []
    ),
    (   Ready == [] -> flush_output(user_output) ; true ).

print_outcome(Name, N, Outcome) :-
    (   outcome_message(Outcome, Kind, Reason)
    ->  flush_output(user_output),
        (   Name == (-)
        ->  format(user_error, "~w: ~s~n", [Kind, Reason])
        ;   format(user_error, "~w:~w: ~w: ~s~n", [Name, N, Kind, Reason])
        )
    ;   true
    ).

% Warnings about line N (a deletion outside the retraction horizon, rtl_horizon.pl).
print_warnings(Name, N) :-
    rtl_take_warnings(Warnings),
    Warnings \== [],
    !,
    flush_output(user_output),
    forall(member(W, Warnings),
           (   Name == (-)
           ->  format(user_error, "warning: ~s~n", [W])
           ;   format(user_error, "~w:~w: warning: ~s~n", [Name, N, W])
           )).
print_warnings(_, _).

outcome_message(rejected(Reason), rejected, Reason).
outcome_message(refused(Reason), error, Reason).
outcome_message(failed(Reason), error, Reason).
outcome_message(halted(Reason), error, Reason).

stop_if_needed(Outcome) :-
    stop_if_needed(Outcome, []).

stop_if_needed(Outcome, Options) :-
    (   Outcome = halted(_)
    ->  throw(rtl_stop(1))
    ;   Outcome \== ok, memberchk(strict(true), Options)
    ->  throw(rtl_stop(1))
    ;   true
    ).

without_bom(Line0, Line) :-
    (   string(Line0), sub_string(Line0, 0, 1, After, "\uFEFF")
    ->  sub_string(Line0, 1, After, 0, Line)
    ;   Line = Line0
    ).

%   with_action_output(:Goal)
%
%   Run Goal with the current output sent where program code's printed text goes
%   (standard error, or the file of --action-output); output lines go to user_output.

with_action_output(Goal) :-
    rtl_action_stream(Stream),
    current_output(Old),
    setup_call_cleanup(set_output(Stream), Goal, set_output(Old)).

%!  rtl_process_line(+Line:string, +Options:list, -Outcome) is det.
%
%   Process one input line: an event, its deletion, a clock line (the clock moves to its
%   time without an event, and the timers it passes fire), or a rule change. Outcome is `ok`,
%   `rejected(Reason)` (a malformed line, counted as rejected), `refused(Reason)` (a
%   control line without `allow_control(true)` in Options, counted as rejected),
%   `failed(Reason)` (the program raised an error or ran out of steps while processing
%   the event, counted as failed) or `halted(Reason)` (program code called halt).

rtl_process_line(Line, Options, Outcome) :-
    rtl_flag(max_term_depth, MaxDepth),
    rtl_parse_event_line(Line, MaxDepth, Parsed),
    rtl_process_parsed(Parsed, Options, Outcome).

%   rtl_process_parsed(+Parsed, +Options, -Outcome): rtl_process_line/3 for a line read
%   already (Parsed as given by rtl_parse_event_line/3).

rtl_process_parsed(Parsed, Options, Outcome) :-
    parsed_outcome(Parsed, Options, Outcome),
    count_outcome(Outcome).

parsed_outcome(blank, _, ok).
parsed_outcome(error(Reason), _, rejected(Reason)).
parsed_outcome(rule(Change, Text), Options, Outcome) :-
    (   memberchk(allow_control(true), Options)
    ->  change_rules(Change, Text, Reason),
        ( var(Reason) -> Outcome = ok ; Outcome = rejected(Reason) )
    ;   Outcome = refused("control lines are disabled (pass --allow-control)")
    ).
parsed_outcome(clock(Time), _, Outcome) :-
    rtl_future_problem(Time, Reason),
    !,
    Outcome = rejected(Reason).
parsed_outcome(clock(Time), _, Outcome) :-       % a heartbeat in the input (rtl_advance_clock/1)
    catch(( rtl_guarded(rtl_advance_clock(Time)), Outcome = ok ),
          Error,
          event_failure(Error, "the clock line", Outcome)).
parsed_outcome(event(_, _, _, End), _, Outcome) :-
    rtl_future_problem(End, Reason),
    !,
    Outcome = rejected(Reason).
parsed_outcome(event(Op, Event, Start, End), _, Outcome) :-
    (   Op == add
    ->  rtl_seen_add(Event, Start, End),
        run_event(add, Event, Start, End, Outcome)
    ;   retraction_outcome(Event, Start, End, Outcome)
    ).

% A retraction of an event that was not added is refused; one of an event older than what
% is remembered cannot be checked (rtl_seen.pl).
retraction_outcome(Event, Start, End, Outcome) :-
    (   rtl_seen_take(Event, Start, End)
    ->  run_event(retract, Event, Start, End, Outcome)
    ;   rtl_seen_horizon(Horizon), End < Horizon         % too old to check
    ->  run_event(retract, Event, Start, End, Outcome)
    ;   event_text(Event, Text),
        format(string(Reason), "retraction of ~s [~w, ~w], which was not added (or was retracted already)",
               [Text, Start, End]),
        Outcome = rejected(Reason)
    ).

run_event(Op, Event, Start, End, Outcome) :-
    catch(( rtl_input(Op, Event, Start, End), Outcome = ok ),
          Error,
          ( rtl_drop_raised,
            event_text(Event, Text),
            event_failure(Error, Text, Outcome) )).

event_failure(Error, _, _) :-                  % the output cannot be written, a stop signal
    ( rtl_output_gone(Error) ; rtl_output_failed(Error, _) ; Error = rtl_signal(_) ),
    !,
    throw(Error).
event_failure(rtl_halted(Why), Text, halted(Reason)) :- !,
    format(string(Reason), "~s while processing ~s", [Why, Text]).
event_failure(Error, Text, failed(Reason)) :-
    error_text(Error, Why),
    format(string(Reason), "~s while processing ~s", [Why, Text]).

count_outcome(ok).
count_outcome(rejected(_)) :- rtl_count(rejected).
count_outcome(refused(_)) :- rtl_count(rejected).
count_outcome(failed(_)) :- rtl_count(failed).
count_outcome(halted(_)) :- rtl_count(failed).

% An event as it is named in messages: writeq text, at most 200 characters.
event_text(Event, Text) :-
    format(string(Text0), "~q", [Event]),
    (   string_length(Text0, L), L > 200
    ->  sub_string(Text0, 0, 197, _, Head),
        string_concat(Head, "...", Text)
    ;   Text = Text0
    ).

change_rules(Change, Text, Reason) :-
    rtl_program(M),
    catch(( Change == add -> ins_event_rule(M:Text) ; atom_string(Label, Text), del_event_rule(M:Label) ),
          Error,
          error_text(Error, Reason)).

% One line of text for an error term (rtl_error_text.pl: never interpreted).
error_text(Error, Text) :-
    rtl_error_text(Error, Text).

% The end of the input: run or drop the postponed synchronized matches. Errors are
% reported through Report (called as call(Report, 0, Outcome)).
end_of_input(Mode, Report) :-
    catch(( ( rtl_flag(flush_timers, true) -> rtl_guarded(rtl_timers_flush) ; true ),
            rtl_guarded(rtl_sync_finish(Mode)), Outcome = ok ),
          Error,
          ( rtl_drop_raised,
            event_failure(Error, "the matches postponed to the end of the input", Outcome) )),
    count_outcome(Outcome),
    call(Report, 0, Outcome),
    stop_if_needed(Outcome).

%!  rtl_feed_lines(+Text:string, +FirstLineNo:integer, -Output:string) is det.
%!  rtl_feed_lines(+Text:string, +FirstLineNo:integer, +Options:list, -Output:string) is det.
%
%   Process a batch of input JSON Lines. Output is a string of lines, each ended by a
%   newline: first, when there is output, the outputs as data (the two lines of
%   rtl_output_data/2, the form in which outputs cross to Python), then the others; a line that is not processed shows up as `!N<TAB>Kind<TAB>Reason` with its
%   line number N and Kind `rejected`, `error` or `halt`. Options: `allow_control(Bool)`
%   (obey control lines; default false), `strict(Bool)` (stop at the first line that is
%   not processed), `bytes(true)` (Text holds the bytes of the lines, codes 0..255, each
%   decoded here as UTF-8 and rejected when it is not: rtl_lines.pl). Processing also
%   stops after a halt. The first line of the input (FirstLineNo 1) loses a leading byte
%   order mark. Everything output by the lines
%   processed is in Output, once. A warning about line N (a deletion outside the retraction
%   horizon) shows up as `?N<TAB>Text`.

rtl_feed_lines(Text, First, Output) :-
    rtl_feed_lines(Text, First, [], Output).

rtl_feed_lines(Text, First, Options, Output) :-
    rtl_output_to(buffer),
    rtl_split_lines(Text, Lines0),
    (   memberchk(bytes(true), Options)
    ->  rtl_flag(max_line_bytes, MaxBytes),
        maplist(byte_line(MaxBytes), Lines0, Lines1)
    ;   Lines1 = Lines0                         % (rtl_parse_event_line/3 checks the length)
    ),
    (   First =:= 1, Lines1 = [L0|Ls]
    ->  without_bom(L0, L1), Lines = [L1|Ls]
    ;   Lines = Lines1
    ),
    with_action_output(feed_lines(Lines, First, Options, Rejections)),
    rtl_take_output_data(Out),
    append(Out, Rejections, All0),
    exclude(==(""), All0, All),
    atomic_list_concat(All, "\n", Joined),
    (   All == [] -> Output = "" ; string_concat(Joined, "\n", Output) ).

% A line of a batch of bytes as rtl_read_line/3 reads it: too long before it is decoded.
byte_line(MaxBytes, Line0, Line) :-
    (   rtl_long_line(Line0, true, MaxBytes, TooLong)
    ->  Line = TooLong
    ;   rtl_utf8_line(Line0, Line)
    ).

feed_lines([], _, _, []).
feed_lines([Line|Lines], N, Options, Rejections) :-
    rtl_process_line(Line, Options, Outcome),
    rtl_take_warnings(Warnings),
    (   Warnings == []
    ->  Rejections = Rejections0
    ;   findall(W, ( member(T, Warnings), format(string(W), "?~w\t~s", [N, T]) ), Ws),
        append(Ws, Rejections0, Rejections)
    ),
    (   Outcome == ok
    ->  Rejections0 = Rest,
        N1 is N + 1,
        feed_lines(Lines, N1, Options, Rest)
    ;   outcome_kind(Outcome, Kind, Reason),
        format(string(R), "!~w\t~w\t~s", [N, Kind, Reason]),
        Rejections0 = [R|Rest],
        (   ( Kind == halt ; memberchk(strict(true), Options) )
        ->  Rest = []
        ;   N1 is N + 1,
            feed_lines(Lines, N1, Options, Rest)
        )
    ).

outcome_kind(rejected(Reason), rejected, Reason).
outcome_kind(refused(Reason), error, Reason).
outcome_kind(failed(Reason), error, Reason).
outcome_kind(halted(Reason), halt, Reason).

%!  rtl_end_of_input(+Mode, -Output:string) is det.
%
%   The input has ended: run (Mode `run`) or discard (`drop`) the postponed synchronized
%   matches (rtl_sync_finish/1); Output as for rtl_feed_lines/3. An error while they run
%   is written to standard error (`error: REASON`) and counted as failed.

rtl_end_of_input(Mode, Output) :-
    rtl_output_to(buffer),
    nb_setval(rtl_end_stopped, false),          % a halt in a postponed match: the caller asks
    with_action_output(catch(end_of_input(Mode, print_outcome(-)), rtl_stop(_),
                             nb_setval(rtl_end_stopped, true))),
    rtl_take_output_data(Lines),
    (   Lines == []
    ->  Output = ""
    ;   atomic_list_concat(Lines, "\n", Joined),
        string_concat(Joined, "\n", Output)
    ).

%!  rtl_heartbeat(+Time:number, -Output:string) is det.
%
%   Move the clock to Time without an event (rtl_advance_clock/1): the timers it passes
%   fire. Output as for rtl_feed_lines/3; an error is written to standard error and counted
%   as failed.

rtl_heartbeat(Time, Output) :-
    rtl_output_to(buffer),
    with_action_output(catch(heartbeat(Time, print_outcome(-)), rtl_stop(_), true)),
    rtl_take_output_data(Lines),
    (   Lines == []
    ->  Output = ""
    ;   atomic_list_concat(Lines, "\n", Joined),
        string_concat(Joined, "\n", Output)
    ).

heartbeat(Time, Report) :-
    catch(( rtl_guarded(rtl_advance_clock(Time)), Outcome = ok ),
          Error,
          event_failure(Error, "the heartbeat", Outcome)),
    count_outcome(Outcome),
    call(Report, 0, Outcome),
    stop_if_needed(Outcome).

%!  rtl_summary(-Text:string) is det.
%!  rtl_summary(+Seconds:number, -Text:string) is det.
%
%   The one-line summary of a run: `retalis: N events in, M derived, K rejected, T s`,
%   with `F failed`, `R retracted`, `D too late to retract` and `L late` before the time
%   when they are not zero.
%   rtl_summary/1 gives the time since the program was loaded.

rtl_summary(Text) :-
    (   nb_current(rtl_run_started, T0), number(T0)
    ->  true
    ;   nb_current(rtl_loaded_at, T0), number(T0)
    ->  true
    ;   get_time(T0)
    ),
    get_time(T1),
    Seconds is T1 - T0,
    rtl_summary(Seconds, Text).

rtl_summary(Seconds, Text) :-
    rtl_stat(events, Events),
    rtl_stat(derived, Derived),
    rtl_stat(rejected, Rejected),
    findall(Part,
            ( member(Name-Label, [failed-failed, retracted-retracted,
                                  too_late-'too late to retract', late-late,
                                  timers_refused-'timers not set (max_timers)']),
              rtl_stat(Name, N), N > 0,
              format(string(Part), ", ~D ~w", [N, Label]) ),
            Parts),
    atomic_list_concat(Parts, Extra),
    format(string(Text), "retalis: ~D events in, ~D derived, ~D rejected~w, ~2f s",
           [Events, Derived, Rejected, Extra, Seconds]).
